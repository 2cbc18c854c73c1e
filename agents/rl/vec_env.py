"""Stable-baselines3's ``VecEnv`` over a native contour-gym vector env.

:class:`NativeVecEnv` runs all ``n_envs`` members as one array program
(``gymnasium.make_vec(id, num_envs=n, vectorization_mode="vector_entry_point")``), instead of
``DummyVecEnv``'s loop over single envs, and speaks SB3's convention:

* The native env auto-resets NEXT_STEP (``metadata["autoreset_mode"]``): a member whose episode
  ended is reset at the following step, which returns its reset observation with reward 0.
  SB3 resets a done env inside ``step_wait`` instead. The adapter does so by a partial reset
  (``reset(options={"reset_mask": done})``, which continues each member's generator as a
  single env's ``reset()`` does), returns the reset observation and puts the last one in the
  member's info as ``terminal_observation``, beside ``TimeLimit.truncated`` (truncated and not
  terminated) and the episode's ``metrics`` (``max_contour_error`` m, ``cycle_time`` s, ...).
* Infos: every member's dict has ``TimeLimit.truncated``; a member whose episode ended also
  has the step's info (``contour_error``, ``failure``, ``reward_components``, ... from the
  vector env's ``_key``-masked info) and ``metrics``; ``full_info=True`` gives the step's info
  to every member, as ``DummyVecEnv`` does (at a cost per step).
* Seeding: ``seed(s)`` then ``reset()`` seeds member ``i`` with ``s + i``, as ``DummyVecEnv``
  seeds env ``i``, so the adapter equals ``DummyVecEnv`` over single envs bit for bit
  (rewards as float32, as SB3's buffers hold them).
* ``flatten=True`` hands SB3 one Box (the Dict's values concatenated in its key order), as
  ``gymnasium.wrappers.FlattenObservation`` does to each single env (the ``env_wrapper`` of
  the shipped configs, :data:`agents.rl.observation.FLATTEN_WRAPPER`): one VecNormalize
  array and an ``MlpPolicy`` instead of a normaliser and an extractor per key, faster per env
  step (``benchmarks/train_throughput.py``); the agent learns from the same numbers.

>>> venv = make_native_vec_env("contour_gym/Feedrate-Corner-v0", n_envs=2)
>>> _ = venv.seed(0)
>>> obs = venv.reset()
>>> obs["feedrate"].shape
(2, 2)
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode
from numpy.typing import NDArray
from stable_baselines3.common.vec_env.base_vec_env import (
    VecEnv,
    VecEnvIndices,
    VecEnvObs,
    VecEnvStepReturn,
)

import contour_gym  # noqa: F401  (registers the ids)
from agents.rl.observation import flatten_obs

Obs = dict[str, NDArray[np.float32]]
class NativeVecEnv(VecEnv):
    """SB3 ``VecEnv`` over a native Gymnasium vector env that auto-resets NEXT_STEP.

    Args:
        venv: The vector env (``metadata["autoreset_mode"]`` NEXT_STEP, Dict observations,
            ``reset(options={"reset_mask": ...})`` for partial resets), as
            ``gymnasium.make_vec(id, num_envs=n, vectorization_mode="vector_entry_point")``
            builds it for a contour-gym id.
        full_info: Give every member the step's info (not only members whose episode ended).
        flatten: Observe one flat Box (module docstring), ``terminal_observation`` too.

    Raises:
        ValueError: for a vector env with another auto-reset mode or a non-Dict observation.
    """

    def __init__(
        self, venv: gym.vector.VectorEnv, full_info: bool = False, flatten: bool = False
    ) -> None:
        mode = venv.metadata.get("autoreset_mode")
        if mode != AutoresetMode.NEXT_STEP:
            raise ValueError(f"NativeVecEnv needs a NEXT_STEP auto-reset vector env, got {mode}")
        if not isinstance(venv.single_observation_space, gym.spaces.Dict):
            raise ValueError(
                f"NativeVecEnv needs Dict observations, got {venv.single_observation_space}"
            )
        self.venv, self.full_info, self.flatten = venv, full_info, bool(flatten)
        space: Any = venv.single_observation_space
        self.keys = tuple(space.spaces)
        if self.flatten:
            space = gym.spaces.flatten_space(space)
        super().__init__(venv.num_envs, space, venv.single_action_space)
        self._actions: NDArray[Any] = np.zeros(venv.action_space.shape or ())
        self._started = False

    # ------------------------------------------------------------- stepping
    def reset(self) -> VecEnvObs:
        """Reset every member (with the seeds of :meth:`seed`, used once, as SB3 does).

        Without a pending seed, every member continues its generator (a fresh start, from
        the OS's entropy, only on the first reset), as ``DummyVecEnv`` does.
        """
        seed, options = self._seeds[0], dict(self._shared_options())
        if seed is None and self._started:
            options["reset_mask"] = np.ones(self.num_envs, dtype=bool)
        obs, _ = self.venv.reset(seed=seed, options=options or None)
        self._started = True
        self._reset_seeds()
        self._reset_options()
        self.reset_infos = [{} for _ in range(self.num_envs)]
        return self._observed(obs)

    def _observed(self, obs: Obs) -> Any:
        return flatten_obs(obs, self.keys, self.num_envs) if self.flatten else obs

    def step_async(self, actions: NDArray[Any]) -> None:
        """Keep the actions ``(n_envs, n)`` for :meth:`step_wait`."""
        self._actions = actions

    def step_wait(self) -> VecEnvStepReturn:
        """Step every member; members whose episode ended are reset in the same step."""
        obs, reward, terminated, truncated, info = self.venv.step(self._actions)
        done = terminated | truncated
        infos = [{"TimeLimit.truncated": t} for t in (truncated & ~terminated).tolist()]
        if self.full_info:
            for i, member in enumerate(infos):
                member.update(member_info(info, i))
        if done.any():
            for i in np.flatnonzero(done).tolist():
                if not self.full_info:
                    infos[i].update(member_info(info, i))
                last = {k: v[i].copy() for k, v in obs.items()}
                infos[i]["terminal_observation"] = (
                    flatten_obs(last, self.keys, None) if self.flatten else last)
            obs, _ = self.venv.reset(options={"reset_mask": done})
        return self._observed(obs), reward.astype(np.float32), done, infos

    def close(self) -> None:
        """Close the vector env."""
        self.venv.close()

    def get_images(self) -> Sequence[NDArray[Any] | None]:
        """Each member's rgb_array (render_mode ``"rgb_array"``), else Nones."""
        images: Any = self.venv.render() if self.render_mode == "rgb_array" else None
        return list(images) if images is not None else [None] * self.num_envs

    # ------------------------------------------------------- env attributes
    def get_attr(self, attr_name: str, indices: VecEnvIndices = None) -> list[Any]:
        """The vector env's attribute, once per index (the members share one env)."""
        value = getattr(self.venv.unwrapped, attr_name)
        return [value for _ in self._get_indices(indices)]

    def set_attr(self, attr_name: str, value: Any, indices: VecEnvIndices = None) -> None:
        """Set an attribute of the vector env; ``indices`` must cover every member."""
        self._every_member(indices, f"set_attr({attr_name!r})")
        setattr(self.venv.unwrapped, attr_name, value)

    def env_method(
        self, method_name: str, *method_args: Any, indices: VecEnvIndices = None, **kwargs: Any
    ) -> list[Any]:
        """Call a method of the vector env once; its result is returned once per member.

        ``indices`` must cover every member: the members share one env, whose methods act on
        all of them (e.g. ``gains_to_action``).
        """
        self._every_member(indices, f"env_method({method_name!r})")
        result = getattr(self.venv.unwrapped, method_name)(*method_args, **kwargs)
        return [result for _ in range(self.num_envs)]

    def env_is_wrapped(
        self, wrapper_class: type[gym.Wrapper], indices: VecEnvIndices = None
    ) -> list[bool]:
        """False for each index: the members are no wrapped single envs."""
        return [False for _ in self._get_indices(indices)]

    def _every_member(self, indices: VecEnvIndices, what: str) -> None:
        if sorted(self._get_indices(indices)) != list(range(self.num_envs)):
            raise ValueError(f"{what} acts on every member of the native vector env at once; "
                             f"got indices {indices!r}")

    def _shared_options(self) -> dict[str, Any]:
        first = self._options[0]
        if any(o != first for o in self._options):
            raise ValueError("the members of a native vector env share one reset's options, "
                             f"got {self._options}")
        return first


def member_info(info: dict[str, Any], i: int) -> dict[str, Any]:
    """Member ``i``'s dict of a vector env's ``_key``-masked info (keys present for ``i``)."""
    out: dict[str, Any] = {}
    for key, value in info.items():
        if key.startswith("_") or not info[f"_{key}"][i]:
            continue
        out[key] = member_info(value, i) if isinstance(value, dict) else _item(value[i])
    return out


def _item(value: Any) -> Any:
    if isinstance(value, np.ndarray):
        return value.copy()
    return value.item() if isinstance(value, np.generic) else value


def make_native_vec_env(
    env_id: str, n_envs: int, *, full_info: bool = False, flatten: bool = False,
    **env_kwargs: Any,
) -> NativeVecEnv:
    """A :class:`NativeVecEnv` of ``n_envs`` members of a registered id.

    Args:
        env_id: A registered id, e.g. ``"contour_gym/CCC-Circle-v0"``.
        n_envs: Members.
        full_info: See :class:`NativeVecEnv`.
        flatten: See :class:`NativeVecEnv`.
        **env_kwargs: The env's keyword arguments.
    """
    venv = gym.make_vec(env_id, num_envs=n_envs, vectorization_mode="vector_entry_point",
                        **env_kwargs)
    return NativeVecEnv(venv, full_info=full_info, flatten=flatten)
