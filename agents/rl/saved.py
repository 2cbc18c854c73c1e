"""Trained stable-baselines3 agents as policies: a model, its VecNormalize stats, a meta file.

An agent folder holds ``model.zip`` (the SB3 model), ``vecnormalize.pkl`` (its observation
statistics; absent when trained without normalisation) and ``meta.yaml``::

    algo: sac
    env_id: contour_gym/CCC-Circle-v0
    env_kwargs: {randomize: true}      # the training env's
    command: python -m agents.rl.train_shipped ppo_ccc_circle
    files: {model.zip: <sha256>, vecnormalize.pkl: <sha256>}   # every file the agent needs

Before the model is first read, every file ``files`` lists must be there with its checksum: a
missing or changed file is refused naming it (an agent without its statistics would act on
raw observations, and worse). A folder whose ``meta.yaml`` lists no files (written before they
were recorded) loads with a warning; :func:`record_files` records them.

Every folder under ``agents/trained/`` is registered as a policy by its name
(:func:`register_saved_agents`, run when :mod:`agents.policies` is imported), so
``agents.policies.make("ppo_ccc_circle", env)`` makes it and ``available()`` lists it; any
other folder loads with ``SavedAgent(path)``. The model is read (and stable-baselines3
imported) when the agent first acts or checks an env, not when it is registered or made.

The policy acts deterministically on the normalised observation, on a batch
(:meth:`SB3Policy.act`) or, with :meth:`SB3Policy.predict`, on one observation or a batch. A
PPO or A2C agent acts by its networks alone (:func:`mean_actions`): ``predict``'s numbers,
bit for bit, at 0.08 against 0.19 ms a call for one observation.
Its :attr:`~agents.policies.Policy.env_kwargs` are the training env's less those that only
vary the training (``randomize``, the world of paths ``path="random"`` and its ``path_options``,
the reward and its weights), so an evaluation builds the env the agent acts in, on the path
it is given.
"""

from __future__ import annotations

import enum
import functools
import hashlib
import pickle
import warnings
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import yaml

from agents.parallel import limit_new_torch
from agents.policy_base import (
    POLICIES,
    Actions,
    Observation,
    Policy,
    batch_size,
    register_policy,
)
from agents.rl.algorithms import Algorithm, algorithm
from agents.rl.observation import flatten_obs
from contour_gym.envs.config import EnvConfig
from contour_gym.files import write_text

TRAINED_DIR = Path(__file__).resolve().parent.parent / "trained"
# env kwargs that vary the training, not the agent's interface (observation, action, machine)
TRAINING_ONLY = ("randomize", "path", "path_options", "reward", "reward_weights")
MODEL_FILE, STATS_FILE, META_FILE = "model.zip", "vecnormalize.pkl", "meta.yaml"


class _Unread(enum.Enum):
    UNREAD = "unread"  # an Enum member: pickled by name, so still itself in another process


UNREAD: Any = _Unread.UNREAD  # the model of an SB3Policy that reads it when first needed


class SB3Policy(Policy):
    """A stable-baselines3 model (and its VecNormalize stats) as a batch-first policy.

    Args:
        model: The SB3 model (``PPO``, ``SAC``, ``TD3``).
        normalizer: The ``VecNormalize`` whose observation statistics the model was trained
            on (its ``normalize_obs`` is applied), or None.
        env_kwargs: The env keyword arguments the agent needs (its training env's, less
            :data:`TRAINING_ONLY`).
        label: Name for messages (the agent's folder name).
        deterministic: Act on the mean action (True) or sample.
        recurrent: The model's policy keeps a state between steps (sb3-contrib's
            RecurrentPPO): :meth:`act` carries it from step to step, and :meth:`reset`
            starts it afresh.
    """

    name = "sb3"

    def __init__(
        self,
        model: Any,
        normalizer: Any = None,
        env_kwargs: Mapping[str, Any] | None = None,
        label: str = "sb3 agent",
        deterministic: bool = True,
        recurrent: bool = False,
    ) -> None:
        self._model, self._normalizer, self.label = model, normalizer, label
        self.deterministic, self.recurrent = deterministic, recurrent
        self._state: Any = None  # a recurrent policy's state, None at an episode's start
        self._env_kwargs = {k: v for k, v in (env_kwargs or {}).items() if k not in TRAINING_ONLY}
        self._keys: tuple[str, ...] | None = None  # the env's Dict order (sorted until reset)

    @property
    def model(self) -> Any:
        """The SB3 model (assignable: the policy then acts with the new one)."""
        self._ensure_read()
        return self._model

    @model.setter
    def model(self, model: Any) -> None:
        self._ensure_read()  # first, so that a later read cannot replace what is set
        self._model = model
        self.__dict__.pop("_observed", None)  # read from the new model when next needed
        self.__dict__.pop("_mean_actions", None)  # (training in place needs no new one)

    @property
    def normalizer(self) -> Any:
        """The ``VecNormalize`` whose observation statistics the model was trained on, or None."""
        self._ensure_read()
        return self._normalizer

    @normalizer.setter
    def normalizer(self, normalizer: Any) -> None:
        self._ensure_read()  # as the model's
        self._normalizer = normalizer

    def _ensure_read(self) -> None:
        if self._model is UNREAD:
            self._read()

    def _read(self) -> None:
        """Read the model and normalizer a subclass was made without (:data:`UNREAD`)."""
        raise ValueError(f"agent {self.label!r} was made without a model")

    @functools.cached_property
    def _observed(self) -> tuple[bool, int, dict[str, tuple[int, ...]]]:
        # (flat, its size, the Dict's shapes), read from the model when first needed: a Box
        # when trained on the flattened Dict (env_wrapper FlattenObservation)
        space = self.model.observation_space
        if isinstance(getattr(space, "spaces", None), Mapping):
            return False, 0, space_shapes(space)
        return True, int(np.prod(space.shape)), {}

    @functools.cached_property
    def _mean_actions(self) -> Callable[[Any], Actions] | None:
        # the model's deterministic actions by its networks alone, when it has a shortcut
        return mean_actions(self.model)

    @property
    def _flat(self) -> bool:
        return self._observed[0]

    @property
    def _flat_size(self) -> int:
        return self._observed[1]

    @property
    def _shapes(self) -> dict[str, tuple[int, ...]]:
        return self._observed[2]

    @property
    def env_kwargs(self) -> dict[str, Any]:
        """The training env's keyword arguments less :data:`TRAINING_ONLY` (a fresh dict)."""
        return dict(self._env_kwargs)

    def reset(self, env: Any = None) -> None:
        """Check that the agent fits ``env`` (single or native vector env).

        Raises:
            ValueError: naming both shapes, for an observation or action space that differs
                from the agent's.
        """
        self._state = None
        if env is None:
            return
        obs_space = getattr(env, "single_observation_space", env.observation_space)
        act_space = getattr(env, "single_action_space", env.action_space)
        theirs = space_shapes(obs_space)
        if self._flat:
            self._keys = tuple(theirs)
            fits = flat_size(theirs) == self._flat_size
        else:
            fits = self._shapes == theirs
        if not fits:
            raise ValueError(f"agent {self.label!r} observes {self._observes()}, which does not "
                             f"fit the env's observation space {theirs}")
        if self.model.action_space.shape != act_space.shape:
            raise ValueError(f"agent {self.label!r} acts with shape {self.model.action_space.shape}"
                             f", the env with {act_space.shape}")

    def act(self, obs: Observation) -> Actions:
        """Actions ``(B, n)`` for a batch of observations (every value ``(B, ...)``).

        Member by member (:func:`by_rows`): each member's action is the model's for its own
        observation alone, whatever else the batch holds.
        """
        n = batch_size(obs)
        if not self.recurrent and self.deterministic and self._mean_actions is not None:
            return self._mean_actions(self._normalized(obs))
        starts = np.full(n, self._state is None) if self.recurrent else None
        actions, state = by_rows(self.model, self._normalized(obs), n, self._state, starts,
                                 self.deterministic)
        if self.recurrent:
            self._state = state
        return actions

    def predict(
        self,
        obs: Observation,
        state: Any = None,
        episode_start: Any = None,
        deterministic: bool = True,
    ) -> tuple[Actions, Any]:
        """SB3's interface on one observation (values ``(n,)``, action ``(n_a,)``) or a batch.

        Raises:
            ValueError: for an observation whose keys or shapes differ from the agent's.
        """
        if not isinstance(obs, Mapping) or (not self._flat and set(obs) != set(self._shapes)):
            got = sorted(obs) if isinstance(obs, Mapping) else type(obs).__name__
            raise ValueError(f"agent {self.label!r} observes {self._observes()}, got {got}")
        given = {k: np.shape(v) for k, v in obs.items()}
        if self._flat:  # a Dict of 1-D values (one observation), or of (B, ...) values
            single = all(len(g) <= 1 for g in given.values())
            size = flat_size(given if single else {k: g[1:] for k, g in given.items()})
            fits = size == self._flat_size and (single or len({g[0] for g in given.values()}) == 1)
        else:
            shapes = self._shapes
            single = all(given[k] == shapes[k] for k in shapes)
            fits = single or all(given[k][1:] == shapes[k] for k in shapes)
        if not fits:
            raise ValueError(f"agent {self.label!r} observes {self._observes()} (or a batch), "
                             f"got {given}")
        batch = {k: np.asarray(v)[None] for k, v in obs.items()} if single else dict(obs)
        actions, state = by_rows(self.model, self._normalized(batch), batch_size(batch), state,
                                 episode_start, deterministic)
        return (actions[0] if single else actions), state

    def _normalized(self, obs: Observation) -> Any:
        arrays: Any = {k: np.asarray(v, dtype=np.float32) for k, v in obs.items()}
        if self._flat:  # the Dict's values in its key order, as FlattenObservation gives them
            keys = self._keys or tuple(sorted(arrays))
            arrays = flatten_obs(arrays, keys, len(next(iter(arrays.values()))))
        if self.normalizer is None:
            return arrays
        return self.normalizer.normalize_obs(arrays)

    def _observes(self) -> Any:
        return f"a flat Box of {self._flat_size}" if self._flat else self._shapes


def row(batch: Any, i: int) -> Any:
    """Row ``i`` of a numpy or torch batch (or a dict of them) as a batch of one, copied."""
    if isinstance(batch, Mapping):
        return {k: row(v, i) for k, v in batch.items()}
    part = batch[i : i + 1]
    return part.clone() if hasattr(part, "clone") else np.array(part)


def by_rows(
    model: Any, batch: Any, n: int, state: Any = None, starts: Any = None,
    deterministic: bool = True,
) -> tuple[Actions, Any]:
    """``model.predict`` on each of the ``n`` rows of ``batch`` alone: actions ``(n, ...)``.

    torch's matrix products round differently for different numbers of rows (float32), and a
    member's episode then drifts from the one it runs alone (encoder counts flip: an agent of
    004's machine peaked at 9.98 um on a random path alone and at 8.47 um beside other paths).
    Row by row, a member acts as it does alone, whatever the batch. A recurrent model's
    ``state`` (its LSTM's, ``(layers, n, hidden)`` arrays) is split and joined along the
    members.

    Args:
        model: A stable-baselines3 (or sb3-contrib) model.
        batch: Normalized observations, ``n`` rows.
        n: The rows.
        state: A recurrent model's state, or None.
        starts: ``episode_start`` per row (a recurrent model), or None.
        deterministic: The mean action (True) or a sample.
    """
    actions, states = [], []
    for i in range(n):
        mine = None if state is None else tuple(np.array(h[:, i : i + 1]) for h in state)
        start = None if starts is None else np.asarray(starts)[i : i + 1]
        action, after = model.predict(row(batch, i), state=mine, episode_start=start,
                                      deterministic=deterministic)
        actions.append(np.asarray(action, dtype=np.float64))
        states.append(after)
    joined = None
    if states and states[0] is not None:
        joined = tuple(np.concatenate([s[j] for s in states], axis=1)
                       for j in range(len(states[0])))
    return np.concatenate(actions), joined


def mean_actions(model: Any) -> Callable[[Any], Actions] | None:
    """:func:`by_rows`' deterministic actions ``(B, n)``, float64, by the model's networks.

    For an on-policy model with a Gaussian policy (PPO, A2C; ``gSDE`` too) on a Box action
    space without squashing, the deterministic action is the actor's mean clipped to the
    space: the same torch operations as ``predict`` on each row alone, so the same numbers
    bit for bit, without ``predict``'s per-call work (setting every module's training mode,
    building the action distribution and checking its arguments). Measured: 0.08 against
    0.19 ms a call for one observation (``ppo_ccc_circle``); the default bench suite on one
    worker, three runs alternating with ``predict``, 16.2 against 17.9 s (medians). None for
    any other model (it acts by ``predict``, row by row).

    Args:
        model: A stable-baselines3 model.
    """
    from stable_baselines3.common.distributions import (
        DiagGaussianDistribution,
        StateDependentNoiseDistribution,
    )
    from stable_baselines3.common.policies import ActorCriticPolicy, BaseModel

    policy = model.policy
    gaussian = (DiagGaussianDistribution, StateDependentNoiseDistribution)
    if not isinstance(policy, ActorCriticPolicy) or any(
            getattr(type(policy), m) is not getattr(ActorCriticPolicy, m)
            for m in ("predict", "_predict", "get_distribution")):
        return None  # an off-policy actor, or a policy that acts its own way
    if (not isinstance(policy.action_dist, gaussian) or policy.squash_output
            or not isinstance(policy.action_space, gym.spaces.Box)):
        return None
    import torch

    shape, low, high = policy.action_space.shape, policy.action_space.low, policy.action_space.high

    def one(tensor: Any) -> Any:
        features = BaseModel.extract_features(policy, tensor, policy.pi_features_extractor)
        return policy.action_net(policy.mlp_extractor.forward_actor(features))

    def act(obs: Any) -> Actions:
        if policy.training:
            policy.set_training_mode(False)
        tensor, _ = policy.obs_to_tensor(obs)
        with torch.no_grad():  # row by row (by_rows), each row a tensor of its own
            n = len(next(iter(tensor.values()))) if isinstance(tensor, Mapping) else len(tensor)
            mean = torch.cat([one(row(tensor, i)) for i in range(n)]).cpu().numpy()
        actions = np.clip(mean.reshape((-1, *shape)), low, high)
        return np.asarray(actions, dtype=np.float64)

    return act


def flat_size(shapes: Mapping[str, tuple[int, ...]]) -> int:
    """Length of a Dict observation of ``shapes`` flattened."""
    return int(sum(np.prod(s, dtype=np.int64) for s in shapes.values()))


def space_shapes(space: Any) -> dict[str, tuple[int, ...]]:
    """``{key: shape}`` of a Dict space (the contour-gym observations), for checks and messages.

    Raises:
        ValueError: for a space that is not a Dict.
    """
    spaces = getattr(space, "spaces", None)
    if not isinstance(spaces, Mapping):
        raise ValueError(f"expected a Dict observation space, got {space}")
    return {k: tuple(s.shape) for k, s in spaces.items()}


class SavedAgent(SB3Policy):
    """A trained agent loaded from its folder (``model.zip``, ``vecnormalize.pkl``, ``meta.yaml``).

    Args:
        path: The agent's folder.
        deterministic: Act on the mean action (True) or sample.

    The model and its statistics are read when the agent first needs them (to act, or to check
    an env against its spaces), not when it is made: a suite builds every policy to check its
    file, and a bench unit builds only its own cells' (``load_suite("default")`` took 1.2-1.3 s
    with its four agents read, and 0.2 s without: reading one imports stable-baselines3 and
    torch). They are read once per process and shared by the agents that read the same
    unchanged files. The model is loaded to act (:func:`load_for_acting`: it has no
    optimizer); to fine-tune an agent, load its ``model.zip`` with the algorithm's ``load``.

    Raises:
        ValueError: for a missing model or meta file (naming the path), or a meta file without
            ``algo`` and ``env_id``. A model file that cannot be read raises when the agent
            first needs it.
    """

    name = "saved_agent"

    def __init__(self, path: str | Path, deterministic: bool = True) -> None:
        folder = Path(path)
        self.folder, self.meta = folder, read_meta(folder)
        model_path = folder / MODEL_FILE
        if not model_path.is_file():
            raise ValueError(f"agent {folder.name!r}: model file {model_path} is missing")
        self._algo = algorithm(self.meta["algo"])
        super().__init__(UNREAD, None, self._interface(), folder.name, deterministic,
                         self._algo.recurrent)

    def _read(self) -> None:
        """Read the model (loaded to act) and its normalizer: when first needed (class doc).

        Raises:
            ValueError: naming the agent and the file, for a file ``meta.yaml`` lists that is
                missing or changed, or one that cannot be read.
        """
        model, stats = self.folder / MODEL_FILE, self.folder / STATS_FILE
        listed = self.meta.get("files")
        if listed is None:
            warnings.warn(f"agent {self.folder.name!r}: {self.folder / META_FILE} lists no files "
                          "to check; agents.rl.saved.record_files(folder) records them",
                          stacklevel=2)
        else:
            _verified(self.folder, tuple(sorted(listed.items())), _stamps(self.folder, listed))
        try:
            self._model, self._normalizer = _loaded(self._algo, model, _stamp(model), stats,
                                                    _stamp(stats))
        except Exception as exc:  # a file SB3 or pickle cannot read, whatever it raises
            raise ValueError(f"agent {self.folder.name!r}: cannot load {model} or {stats}: "
                             f"{type(exc).__name__}: {exc}") from exc
        limit_new_torch()  # torch may have been imported just now, inside a unit

    def _interface(self) -> dict[str, Any]:
        """The training env kwargs, with the observation version of its id when they lack it.

        A -v1 agent run on a -v0 id (or the other way round) gets the observation it was
        trained on, in an env of its own.
        """
        kwargs = dict(self.meta.get("env_kwargs") or {})
        if "observation" not in kwargs and self.meta["env_id"] in gym.registry:
            kwargs["observation"] = gym.spec(self.meta["env_id"]).kwargs.get(
                "observation", EnvConfig.observation)
        return kwargs

    @property
    def env_id(self) -> str:
        """The id the agent was trained on."""
        return str(self.meta["env_id"])


def file_digest(path: Path) -> str:
    """The SHA-256 of a file's bytes, in hex."""
    return hashlib.sha256(path.read_bytes()).hexdigest()


def record_files(folder: str | Path) -> dict[str, str]:
    """Record in ``folder``'s ``meta.yaml`` the checksum of each file the agent has; them.

    The model and, if present, its statistics: saved that way, loading refuses the agent
    when either is later missing or changed.
    """
    folder = Path(folder)
    meta = read_meta(folder)
    meta["files"] = {name: file_digest(folder / name) for name in (MODEL_FILE, STATS_FILE)
                     if (folder / name).is_file()}
    write_text(folder / META_FILE, yaml.safe_dump(meta, sort_keys=False))
    return dict(meta["files"])


def _stamps(folder: Path, listed: Mapping[str, str]) -> tuple[object, ...]:
    return tuple(_stamp(folder / name) for name in sorted(listed))


@functools.lru_cache(maxsize=64)
def _verified(folder: Path, listed: tuple[tuple[str, str], ...], stamps: object) -> None:
    """Check each listed file is there with its checksum (once while the files are unchanged)."""
    for name, digest in listed:
        path = folder / name
        if not path.is_file():
            raise ValueError(f"agent {folder.name!r}: {path} is missing ({META_FILE} lists it)")
        if file_digest(path) != digest:
            raise ValueError(f"agent {folder.name!r}: {path} is corrupt or changed since the "
                             f"agent was saved (its SHA-256 is not the one {META_FILE} lists)")


def _stamp(path: Path) -> tuple[int, int] | None:
    """A file's modification time and size (None: no such file), to key :func:`_loaded`."""
    try:
        st = path.stat()
    except FileNotFoundError:
        return None
    return st.st_mtime_ns, st.st_size


@functools.lru_cache(maxsize=16)
def _loaded(
    algo: Algorithm, model_path: Path, model_stamp: object, stats: Path, stats_stamp: object
) -> tuple[Any, Any]:
    """An agent's model and normalizer, loaded once per process while their files are unchanged.

    Acting changes neither (the state of a recurrent policy lives in its :class:`SB3Policy`),
    so every policy made from the same files shares them: a bench run makes one per cell.
    """
    model = load_for_acting(algo.load_class(), model_path)
    return model, None if stats_stamp is None else load_normalizer(stats)


class _NoOptimizer:
    """What a model loaded to act has for an optimizer: none that keeps state or steps.

    Making torch's own (stable-baselines3's policies make an Adam as they are built) imports
    ``torch._dynamo`` on its first call, in every process: 0.8-1.3 s measured, more than the
    rest of loading a saved agent.
    """

    def __init__(self, params: Any, **kwargs: Any) -> None:
        del params, kwargs

    def load_state_dict(self, state: Any, strict: bool = True) -> None:
        """Drop the saved optimizer's state (acting does not use it)."""
        del state, strict

    def state_dict(self) -> dict[str, Any]:
        """No state."""
        return {}


def load_for_acting(cls: Any, path: Path) -> Any:
    """A stable-baselines3 model of class ``cls`` loaded from ``path`` on the CPU, to act only.

    The same weights and :meth:`predict` as ``cls.load(path)``; its policy's optimizer is a
    stand-in (:class:`_NoOptimizer`), so the model cannot be trained further.
    """
    from stable_baselines3.common.save_util import load_from_zip_file

    data, _, _ = load_from_zip_file(path, device="cpu")
    kwargs = {**((data or {}).get("policy_kwargs") or {}), "optimizer_class": _NoOptimizer}
    return cls.load(path, device="cpu", custom_objects={"policy_kwargs": kwargs})


def load_normalizer(path: Path) -> Any:
    """A saved ``VecNormalize`` (without its env) set not to update its statistics."""
    with path.open("rb") as f:
        normalizer = pickle.load(f)  # noqa: S301 (the project's own agent files)
    normalizer.training, normalizer.norm_reward = False, False
    return normalizer


def read_meta(folder: Path) -> dict[str, Any]:
    """The agent's ``meta.yaml`` (``algo``, ``env_id``, ``env_kwargs``, ``command``).

    Raises:
        ValueError: for a missing or malformed file, naming its path.
    """
    path = folder / META_FILE
    if not path.is_file():
        raise ValueError(f"agent {folder.name!r}: meta file {path} is missing")
    meta = yaml.safe_load(path.read_text(encoding="utf-8"))
    if not isinstance(meta, dict) or not all(isinstance(meta.get(k), str) for k in
                                              ("algo", "env_id")):
        raise ValueError(f"{path}: must be a mapping with 'algo' and 'env_id' strings")
    if not isinstance(meta.get("env_kwargs") or {}, dict):
        raise ValueError(f"{path}: env_kwargs must be a mapping")
    files = meta.get("files")
    if files is not None and not (isinstance(files, dict) and MODEL_FILE in files and all(
            isinstance(k, str) and isinstance(v, str) and len(v) == 64 for k, v in files.items())):
        raise ValueError(f"{path}: files must map each file name (model.zip among them) to "
                         "its SHA-256 in hex")
    return meta


def register_saved_agents(root: str | Path = TRAINED_DIR, replace: bool = False) -> list[str]:
    """Register every agent folder under ``root`` as a policy named after the folder.

    A folder is checked when its policy is made (:class:`SavedAgent`: a missing model or
    meta file fails then, naming the file) and its model read when the agent first acts.

    Args:
        root: The folder holding agent folders (default ``agents/trained``).
        replace: Replace registrations of the same names.

    Returns:
        The registered names.
    """
    base = Path(root)
    names = []
    for folder in sorted(p for p in base.iterdir() if p.is_dir()) if base.is_dir() else []:
        if folder.name.startswith((".", "_")):
            continue
        if folder.name in POLICIES.names() and not replace:
            continue
        register_policy(folder.name, functools.partial(SavedAgent, folder), replace=replace)
        names.append(folder.name)
    return names


register_saved_agents()  # agents/trained/*, when agents.policies is imported
