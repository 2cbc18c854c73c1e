"""Reinforcement-learning agents (stable-baselines3) for the contour-gym envs."""
