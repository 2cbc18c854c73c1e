"""Hyperparameters in rl-baselines3-zoo's format: ``configs/rl/<algo>.yml``.

One block per env id, as rl-zoo reads them (``python -m rl_zoo3.train --algo ppo --env
contour_gym/CCC-Circle-v0 --gym-packages contour_gym --conf-file configs/rl/ppo.yml`` trains
from the same file)::

    contour_gym/CCC-Circle-v0:
      n_envs: 16                      # members of the vector env
      n_timesteps: 200000             # env steps (over all members)
      policy: MlpPolicy               # on the flattened Dict observation
      normalize: true                 # VecNormalize: true, false or its kwargs as a mapping
      env_wrapper: gymnasium.wrappers.FlattenObservation  # or null (MultiInputPolicy)
      env_kwargs: {decision_ticks: 10}
      policy_kwargs: {net_arch: [64, 64]}
      n_steps: 256                    # ... and the algorithm's constructor arguments
      batch_size: 512

The file is read with ``yaml.safe_load`` and checked before any work starts: an unknown key,
or a value of the wrong type (checked against the stable-baselines3 constructor's own
annotations), is a ValueError naming the file, the env id and the key. ``learning_rate`` and
``clip_range`` may be rl-zoo's ``lin_<value>`` (linear decay to 0); off-policy blocks may
give rl-zoo's ``noise_type`` (``normal`` or ``ornstein-uhlenbeck``) and ``noise_std``.
"""

from __future__ import annotations

import copy
import importlib.resources
import inspect
import re
import types
import typing
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from agents.rl.algorithms import algorithm

NOISE_TYPES = ("normal", "ornstein-uhlenbeck")
SCHEDULE_KEYS = ("learning_rate", "clip_range", "clip_range_vf")
# constructor arguments the trainer sets itself (or that name Python classes)
RESERVED = frozenset({
    "env", "seed", "verbose", "tensorboard_log", "device", "_init_setup_model", "action_noise",
    "replay_buffer_class", "rollout_buffer_class",
})
_LIN = re.compile(r"lin_([0-9.eE+-]+)")


def algo_class(algo: str) -> Any:
    """The class of the registered RL algorithm ``algo`` (:mod:`agents.rl.algorithms`).

    Raises:
        ValueError: for an unknown algo, listing the accepted ones, or one whose package is
            not installed, saying how to install it.
    """
    return algorithm(algo).load_class()


@dataclass(frozen=True)
class RunConfig:
    """One env id's checked block of an algo's config.

    Attributes:
        algo: ``ppo``, ``sac`` or ``td3``.
        env_id: The registered id.
        block: The block as written (YAML types), overrides applied.
        source: The file (or ``"overrides"``) it came from, for messages.
    """

    algo: str
    env_id: str
    block: dict[str, Any]
    source: str = ""

    @property
    def n_envs(self) -> int:
        """Members of the training vector env (default 1)."""
        return int(self.block.get("n_envs", 1))

    @property
    def n_timesteps(self) -> int:
        """Env steps to train for."""
        return int(self.block["n_timesteps"])

    @property
    def env_kwargs(self) -> dict[str, Any]:
        """The env's keyword arguments."""
        return dict(self.block.get("env_kwargs") or {})

    @property
    def normalize(self) -> dict[str, Any] | None:
        """VecNormalize keyword arguments (rl-zoo: ``gamma`` is the algo's), None when off."""
        value = self.block.get("normalize", False)
        if value is False:
            return None
        kwargs = {} if value is True else dict(value)
        if "gamma" in self.block:
            kwargs["gamma"] = float(self.block["gamma"])
        return kwargs

    def model_kwargs(self, n_actions: int) -> dict[str, Any]:
        """The SB3 constructor's keyword arguments (policy included, env and seed not).

        Args:
            n_actions: The env's action length (for rl-zoo's ``noise_type``).
        """
        from stable_baselines3.common.noise import NormalActionNoise, OrnsteinUhlenbeckActionNoise
        from stable_baselines3.common.utils import LinearSchedule

        zoo = {"n_envs", "n_timesteps", "normalize", "env_wrapper", "env_kwargs", "noise_type",
               "noise_std"}
        # copies: SB3 writes into policy_kwargs (e.g. use_sde)
        out = {k: copy.deepcopy(v) for k, v in self.block.items() if k not in zoo}
        for key in SCHEDULE_KEYS:
            if isinstance(out.get(key), str):
                out[key] = LinearSchedule(_lin(out[key]), 0.0, 1.0)
        if isinstance(out.get("train_freq"), list):
            out["train_freq"] = tuple(out["train_freq"])
        noise = self.block.get("noise_type")
        if noise is not None:
            cls = NormalActionNoise if noise == "normal" else OrnsteinUhlenbeckActionNoise
            sigma = float(self.block.get("noise_std", 0.1)) * np.ones(n_actions)
            out["action_noise"] = cls(mean=np.zeros(n_actions), sigma=sigma)
        return out


def _lin(text: str) -> float:
    match = _LIN.fullmatch(text)
    if match is None:
        raise ValueError(f"not a lin_<value> schedule: {text!r}")
    return float(match.group(1))


def default_config_file(algo: str) -> Path:
    """The shipped ``configs/rl/<algo>.yml`` (inside the package as ``agents/configs``).

    Raises:
        ValueError: for an unknown algo, or one with no shipped config (give a file).
    """
    algorithm(algo)  # unknown algos are refused first
    path = Path(str(importlib.resources.files("agents") / "configs" / "rl" / f"{algo}.yml"))
    if not path.is_file():
        raise ValueError(f"no shipped config for algo {algo!r}: give a config file in "
                         "rl-baselines3-zoo's format (contour-gym train --config FILE)")
    return path


def load_config(
    algo: str,
    env_id: str,
    config_file: str | Path | None = None,
    overrides: Mapping[str, Any] | None = None,
) -> RunConfig:
    """The checked block of ``env_id`` in an algo's rl-zoo config, with ``overrides``.

    Args:
        algo: ``ppo``, ``sac`` or ``td3``.
        env_id: A registered id, a key of the file.
        config_file: The YAML file (None: the shipped ``configs/rl/<algo>.yml``).
        overrides: Keys replacing the block's (checked as the file's are).

    Raises:
        ValueError: for an unknown algo, an unreadable file, a file that is not a mapping of
            env ids to mappings, a missing env id, an unknown key or a value of the wrong type,
            naming the file, the env id and the key.
    """
    path = Path(config_file) if config_file is not None else default_config_file(algo)
    try:
        data = yaml.safe_load(path.read_text(encoding="utf-8"))
    except (OSError, yaml.YAMLError) as exc:
        raise ValueError(f"{path}: cannot read the config: {' '.join(str(exc).split())}") from None
    if not isinstance(data, dict) or not all(isinstance(v, dict) for v in data.values()):
        raise ValueError(f"{path}: must map env ids to mappings of hyperparameters")
    if env_id not in data:
        raise ValueError(f"{path}: no block for env id {env_id!r}; configured: "
                         f"{', '.join(map(str, data))}")
    block = dict(data[env_id])
    check_block(algo, env_id, block, str(path))
    if overrides:
        check_block(algo, env_id, dict(overrides), "overrides", partial=True)
        block.update(copy.deepcopy(dict(overrides)))
    return RunConfig(algo, env_id, block, str(path))


def check_block(
    algo: str, env_id: str, block: dict[str, Any], source: str, partial: bool = False
) -> None:
    """Check one env id's block (see the module docstring).

    Args:
        algo: The algo whose constructor the block feeds.
        env_id: The block's env id (for messages).
        block: The block.
        source: The file it came from (for messages).
        partial: The block may lack the required keys (``n_timesteps``, ``policy``).

    Raises:
        ValueError: naming ``source``, ``env_id`` and the offending key.
    """
    cls = algo_class(algo)
    where = f"{source}: {env_id}"
    checks = _zoo_checks(algo, cls)
    params = inspect.signature(cls.__init__).parameters
    for key, value in block.items():
        if not isinstance(key, str):
            raise ValueError(f"{where}: key {key!r} is not a string")
        if key in checks:
            problem = checks[key](value)
        elif key in params and key not in RESERVED and key != "policy_kwargs":
            problem = _check_annotation(key, value, params[key].annotation)
        else:
            accepted = sorted(set(checks) | (set(params) - RESERVED - {"self"}))
            raise ValueError(f"{where}: unknown key {key!r} for {algo}; accepted: "
                             f"{', '.join(accepted)}")
        if problem:
            raise ValueError(f"{where}: {key}: {problem}, got {value!r}")
    policy = getattr(cls, "policy_aliases", {}).get(block.get("policy"))
    if policy is not None and isinstance(block.get("policy_kwargs"), Mapping):
        problem = _check_policy_kwargs(policy, block["policy_kwargs"])
        if problem:
            raise ValueError(f"{where}: policy_kwargs: {problem}")
    missing = [k for k in ("n_timesteps", "policy") if k not in block]
    if missing and not partial:
        raise ValueError(f"{where}: missing key(s) {', '.join(missing)}")


Check = Callable[[Any], str]


def _zoo_checks(algo: str, cls: Any) -> dict[str, Check]:
    # rl-zoo's own keys, beside the constructor's arguments; each returns "" when fine
    policies = sorted(getattr(cls, "policy_aliases", {}))
    checks: dict[str, Check] = {
        "n_envs": lambda v: "" if _is_int(v) and v >= 1 else "must be an integer >= 1",
        "n_timesteps": lambda v: "" if _is_steps(v) else "must be a whole number >= 1",
        "policy": lambda v: "" if v in policies else f"must be one of {', '.join(policies)}",
        "normalize": _check_normalize,
        "env_wrapper": lambda v: "" if v is None or isinstance(v, (str, list, dict))
        else "must be null, a class path, a list or a mapping",
        "env_kwargs": lambda v: "" if v is None or _is_str_mapping(v)
        else "must be a mapping of env keyword arguments",
        "policy_kwargs": lambda v: "" if v is None or _is_str_mapping(v)
        else "must be a mapping (e.g. {net_arch: [64, 64]}), not a string to eval",
    }
    if algorithm(algo).off_policy:
        checks["noise_type"] = lambda v: "" if v is None or v in NOISE_TYPES \
            else f"must be one of {', '.join(NOISE_TYPES)}"
        checks["noise_std"] = lambda v: "" if _is_float(v) and v >= 0 else "must be a number >= 0"
    return checks


def _check_policy_kwargs(policy: type, kwargs: Mapping[str, Any]) -> str:
    # the policy class' own arguments (SB3 passes the spaces and the schedule itself); checked
    # before a run folder is made, so a typo never leaves one behind
    params = inspect.signature(policy.__init__).parameters  # type: ignore[misc]
    if any(p.kind is inspect.Parameter.VAR_KEYWORD for p in params.values()):
        return ""
    own = [k for k in params if k not in ("self", "observation_space", "action_space",
                                          "lr_schedule")]
    unknown = sorted(set(kwargs) - set(own))
    if unknown:
        return (f"unknown argument(s) {', '.join(map(repr, unknown))} of {policy.__name__} "
                f"(accepted: {', '.join(own)})")
    return ""


def _check_normalize(value: Any) -> str:
    if isinstance(value, bool):
        return ""
    if not _is_str_mapping(value):
        return "must be true, false or a mapping of VecNormalize keyword arguments"
    from stable_baselines3.common.vec_env import VecNormalize

    params = inspect.signature(VecNormalize.__init__).parameters
    for key, item in value.items():
        if key in ("self", "venv") or key not in params:
            accepted = ", ".join(k for k in params if k not in ("self", "venv"))
            return f"unknown VecNormalize argument {key!r} (accepted: {accepted})"
        problem = _check_annotation(key, item, params[key].annotation)
        if problem:
            return f"{key} {problem}"
    return ""


def _check_annotation(key: str, value: Any, annotation: Any) -> str:
    if key in SCHEDULE_KEYS and isinstance(value, str):
        return "" if _LIN.fullmatch(value) else "must be a number or lin_<value>"
    if _fits(value, annotation):
        return ""
    return f"must be of type {_describe(annotation)}"


def _fits(value: Any, ann: Any) -> bool:
    """Whether a YAML value fits a constructor annotation (no class or callable does)."""
    origin, args = typing.get_origin(ann), typing.get_args(ann)
    if ann is Any:
        return True
    if origin in (typing.Union, types.UnionType):
        return any(_fits(value, a) for a in args)
    if ann is type(None):
        return value is None
    simple: dict[Any, Callable[[Any], bool]] = {
        bool: lambda v: isinstance(v, bool), int: _is_int, float: _is_float,
        str: lambda v: isinstance(v, str), dict: _is_str_mapping,
    }
    if ann in simple:
        return simple[ann](value)
    if origin is dict:
        return _is_str_mapping(value)
    if origin is tuple:
        return (isinstance(value, (list, tuple)) and len(value) == len(args)
                and all(_fits(v, a) for v, a in zip(value, args, strict=True)))
    if origin is list:
        return isinstance(value, list) and all(_fits(v, args[0]) for v in value)
    return False


def _describe(ann: Any) -> str:
    text = str(ann).replace("typing.", "").replace("collections.abc.", "")
    return text.replace("<class '", "").replace("'>", "")


def _is_int(v: Any) -> bool:
    return isinstance(v, int) and not isinstance(v, bool)


def _is_float(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and bool(np.isfinite(v))


def _is_steps(v: Any) -> bool:
    return _is_float(v) and float(v) >= 1 and float(v).is_integer()


def _is_str_mapping(v: Any) -> bool:
    return isinstance(v, dict) and all(isinstance(k, str) for k in v)


def dump_block(config: RunConfig) -> str:
    """The block as rl-zoo YAML (``{env_id: block}``), as a run folder keeps it."""
    return yaml.safe_dump({config.env_id: _plain(config.block)}, sort_keys=False)


def _plain(value: Any) -> Any:
    # YAML-safe: tuples as lists, numpy scalars as Python numbers
    if isinstance(value, Mapping):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    return value.item() if isinstance(value, np.generic) else value
