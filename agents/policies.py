"""Reference policies: a registry of batch-first policies for the contouring envs.

A policy acts on a *batch*: :meth:`Policy.act` takes the env's ``Dict`` observation with a
leading batch dimension, as the native vector env returns it (``gymnasium.make_vec(id,
num_envs=B)``; a single env's observation is B = 1 after ``{k: v[None] for k, v in
obs.items()}``), and returns actions of shape ``(B, n)``. :meth:`Policy.reset` starts a batch of
episodes and hands the policy the env it acts in (policies that speak in CCC gains read the
env's action map there). :attr:`Policy.env_kwargs` are the env keyword arguments the policy
needs the env built with (e.g. the CNC's own path planning); :func:`agents.evaluate.run_policy`
merges them and refuses a conflicting explicit argument.

Policies are made by name from :data:`POLICIES` (``make_policy(name, **params)``); register
your own with :func:`register_policy`:

>>> policy = make_policy("cnc_lookahead", tolerance=5e-5)
>>> sorted(policy.env_kwargs.items())
[('feedrate_override', 1.0), ('path_control', 'G64'), ('path_tolerance', 5e-05)]
>>> import numpy as np
>>> policy.act({"feedrate": np.ones((3, 2), np.float32)}).shape
(3, 1)
"""

from __future__ import annotations

from typing import Any

from agents.policy_base import (
    LOOKAHEAD_MODES,
    POLICIES,
    Actions,
    CNCLookahead,
    ConstantPolicy,
    Observation,
    Policy,
    PolicyEntry,
    action_size,
    batch_size,
    make_policy,
    register_policy,
)


def _load_families() -> None:
    # the reference families register themselves on import (into agents.policy_base's
    # registry), and so do the trained agents of agents/trained/ (agents.rl.saved; each loads
    # when it is made); imported on first use, as they import skfuzzy and stable-baselines3
    from agents import ccc_policies, feedrate_policies  # noqa: F401
    from agents.rl import guard, saved  # noqa: F401


POLICIES.add_loader(_load_families)


def available() -> list[str]:
    """Sorted names of the registered policies (the reference families' included).

    >>> {"no_ccc", "pid_ccc", "fuzzy_pid_ccc", "fuzzy_feedrate"} <= set(available())
    True
    """
    return sorted(POLICIES.names())


def make(name: str, env: Any = None, **params: Any) -> Policy:
    """A new policy ``name`` (:func:`make_policy`), reset on ``env`` if one is given.

    Resetting checks that the policy fits the env (its action map, range or kind) before a
    harness steps it.

    Args:
        name: A registered name (:func:`available`).
        env: An env (single or native vector) to :meth:`Policy.reset` the policy on, or None.
        **params: The policy's parameters.

    Raises:
        ValueError: see :func:`make_policy`; and whatever :meth:`Policy.reset` raises for an
            env the policy cannot act in.
    """
    policy = make_policy(name, **params)
    if env is not None:
        policy.reset(env)
    return policy


__all__ = [
    "LOOKAHEAD_MODES",
    "POLICIES",
    "Actions",
    "CNCLookahead",
    "ConstantPolicy",
    "Observation",
    "Policy",
    "PolicyEntry",
    "action_size",
    "available",
    "batch_size",
    "make",
    "make_policy",
    "register_policy",
]
