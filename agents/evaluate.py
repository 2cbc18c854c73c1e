"""One policy on one env: run episodes to their end and return the episode's metrics.

:func:`run_policy` runs one episode; :func:`run_policy_batch` runs ``num_envs`` episodes at
once as members of the native vector env (member i seeded ``seed + i``, so member i equals
``run_policy(..., seed=seed + i)`` bit for bit). The env is built with the policy's
:attr:`~agents.policies.Policy.env_kwargs` merged into the explicit env arguments; an
explicit argument that conflicts with what the policy needs raises ValueError. The policy's
arguments override the registered id's own defaults (e.g. ``Feedrate-Corner-v0``'s G61).
:func:`evaluate` runs several episodes of a policy (or a policy's name) the same way and
averages their metrics. :func:`make_vector_env` and :func:`run_episodes` are the two halves of
:func:`run_policy_batch`, for a harness that runs several policies on one env (every policy
that needs the same env arguments) or keeps a member's per-tick trace.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping, Sequence
from typing import Any, cast, overload

import gymnasium as gym
import numpy as np
from numpy.typing import NDArray

import contour_gym  # noqa: F401  (registers the ids)
from agents.policies import Policy, make
from contour_gym.envs.base import ContourVectorEnv
from contour_gym.limits import check_size
from contour_gym.loop import Trace

EVAL_ROUND = 1024
"""Members of the vector env an evaluation of many episodes runs at a time: its memory is one
round's, and its results one array per key (:class:`Episodes`)."""
EPISODE_BYTES = 256  # an episode's results: about 20 values of 8 bytes

EnvSpec = str | Mapping[str, Any]


def env_arguments(
    env_id_or_kwargs: EnvSpec, policy: Policy, env_kwargs: Mapping[str, Any]
) -> tuple[str, dict[str, Any]]:
    """The env id and the keyword arguments to build it with for ``policy``.

    Args:
        env_id_or_kwargs: A registered id, or a dict ``{"id": id, **env kwargs}``.
        policy: The policy (its ``env_kwargs`` are merged in).
        env_kwargs: Explicit env keyword arguments (on top of the dict's).

    Raises:
        ValueError: for a dict without an ``"id"``, an argument given twice with different
            values, or an explicit argument that conflicts with the policy's, naming both.
    """
    if isinstance(env_id_or_kwargs, str):
        env_id, explicit = env_id_or_kwargs, {}
    elif isinstance(env_id_or_kwargs, Mapping) and isinstance(env_id_or_kwargs.get("id"), str):
        explicit = dict(env_id_or_kwargs)
        env_id = explicit.pop("id")
    else:
        raise ValueError(f"expected an env id or a dict with an 'id', got {env_id_or_kwargs!r}")
    _merge(explicit, env_kwargs, "the keyword arguments")
    merged = dict(explicit)
    _merge(merged, policy.env_kwargs, f"policy {policy.name!r} (it needs the env built so)")
    return env_id, merged


def _merge(into: dict[str, Any], more: Mapping[str, Any], what: str) -> None:
    for key, value in more.items():
        if key in into and not _same(into[key], value):
            raise ValueError(f"env argument {key}={into[key]!r} conflicts with {key}={value!r} "
                             f"from {what}")
        into[key] = value


def _same(a: Any, b: Any) -> bool:
    # numbers and sequences of numbers compare by value ((0.2, 2.0) == [0.2, 2.0] == array)
    try:
        if all(isinstance(x, (int, float, np.number, tuple, list, np.ndarray)) for x in (a, b)):
            return bool(np.array_equal(a, b))
        return a is b or bool(a == b)
    except (TypeError, ValueError):  # an ambiguous or failing comparison counts as a conflict
        return False


def run_policy_batch(
    env_id_or_kwargs: EnvSpec,
    policy: Policy,
    *,
    num_envs: int = 1,
    seed: int = 0,
    **env_kwargs: Any,
) -> dict[str, NDArray[Any]]:
    """Run one episode per member of a native vector env with ``policy``, each to its end.

    Args:
        env_id_or_kwargs: A registered id, or a dict ``{"id": id, **env kwargs}``.
        policy: The policy; ``reset(env)`` is called once, then ``act`` on every step.
        num_envs: Members (episodes) B.
        seed: Member i is seeded ``seed + i``.
        **env_kwargs: Explicit env keyword arguments.

    Returns:
        Arrays (B,): the episode's ``info["metrics"]`` (``cycle_time``, ``max_contour_error``,
        ``finished``, ...), ``return`` (the sum of the rewards), ``failed`` (the env's failure
        rule ended it), ``truncated``, ``steps``, and ``tolerance`` (the env's, m).

    Raises:
        ValueError: see :func:`env_arguments`; and whatever the env raises for its arguments.
    """
    venv = make_vector_env(env_id_or_kwargs, policy, num_envs=num_envs, **env_kwargs)
    try:
        out, _ = run_episodes(venv, policy, seed=seed)
    finally:
        venv.close()
    return out


def make_vector_env(
    env_id_or_kwargs: EnvSpec,
    policy: Policy,
    *,
    num_envs: int = 1,
    record: bool = False,
    **env_kwargs: Any,
) -> gym.vector.VectorEnv:
    """The native vector env ``policy`` runs in (:func:`env_arguments`), ``num_envs`` members.

    Args:
        env_id_or_kwargs: A registered id, or a dict ``{"id": id, **env kwargs}``.
        policy: The policy (its ``env_kwargs`` are merged in).
        num_envs: Members B.
        record: Keep every member's per-tick trace (the env's ``render_mode="rgb_array"``),
            for :func:`run_episodes`'s ``trace_member``.
        **env_kwargs: Explicit env keyword arguments.

    Raises:
        ValueError: see :func:`env_arguments`; and whatever the env raises for its arguments.
    """
    env_id, kwargs = env_arguments(env_id_or_kwargs, policy, env_kwargs)
    if record:
        kwargs["render_mode"] = "rgb_array"
    return gym.make_vec(env_id, num_envs=num_envs, **kwargs)


def run_episodes(
    venv: gym.vector.VectorEnv, policy: Policy, *, seed: int = 0, trace_member: int | None = None
) -> tuple[dict[str, NDArray[Any]], Trace | None]:
    """Reset ``venv`` (member i seeded ``seed + i``) and run every member's episode to its end.

    The env may have run other policies before: each call starts every member afresh.

    Args:
        venv: A native vector env from :func:`make_vector_env` (built for ``policy``).
        policy: The policy; ``reset(venv)`` is called once, then ``act`` on every step.
        seed: Seed of member 0.
        trace_member: Also return this member's per-tick trace of its episode (the env must
            record: ``make_vector_env(..., record=True)``); None: no trace.

    Returns:
        The arrays (B,) of :func:`run_policy_batch`, and the member's :class:`Trace` (batch
        dimension 1, time from 0 at the reset, NaN rows after its end) or None.

    Raises:
        ValueError: for a ``trace_member`` out of range or an env that does not record.
    """
    task = cast(ContourVectorEnv, venv.unwrapped).task
    n = task.batch
    if trace_member is not None and not (0 <= trace_member < n and task.loop.record):
        raise ValueError(f"trace_member={trace_member!r} needs a member of a recording env "
                         f"(make_vector_env(..., record=True)); the env has {n} member(s), "
                         f"recording {task.loop.record}")
    start = task.loop.tick  # a reset restarts the members, not the loop's clock or record
    obs, _ = venv.reset(seed=seed, options={"keep_paths": True})  # later episodes are unused
    policy.reset(venv)
    out = _episodes(venv, policy, obs, n)
    out["tolerance"] = np.full(n, task.tolerance)
    if trace_member is None:
        return out, None
    ticks = int(out["steps"][trace_member]) * task.config.decision_ticks
    # the record now starts at trace_start (earlier episodes' rows dropped, ServoLoop.step)
    return out, task.loop.trace(trace_member).window(start - task.loop.trace_start, ticks)


def _episodes(venv: Any, policy: Policy, obs: Mapping[str, Any], n: int) -> dict[str, NDArray[Any]]:
    # each member's first episode, to its end (later, auto-reset episodes are ignored)
    live = np.ones(n, dtype=bool)
    out: dict[str, NDArray[Any]] = {
        "return": np.zeros(n), "failed": np.zeros(n, dtype=bool),
        "truncated": np.zeros(n, dtype=bool), "steps": np.zeros(n, dtype=np.int64),
    }
    metrics: dict[str, NDArray[Any]] = {}
    step = 0
    while live.any():
        obs, reward, terminated, truncated, info = venv.step(_checked(policy, obs, venv, step))
        step += 1
        out["return"][live] += reward[live]
        out["steps"][live] += 1
        ended = live & (terminated | truncated)
        if ended.any():
            out["failed"][ended] = info["failure"][ended]
            out["truncated"][ended] = truncated[ended]
            for key, value in info["metrics"].items():
                if not key.startswith("_"):
                    metrics.setdefault(key, np.zeros_like(value))[ended] = value[ended]
        live &= ~ended
    return {**metrics, **out}


def _checked(policy: Policy, obs: Mapping[str, Any], venv: Any, step: int) -> NDArray[Any]:
    # the policy's actions, refused naming the policy, the scenario and the step if not finite
    actions = np.asarray(policy.act(obs), dtype=float)
    bad = ~np.isfinite(actions).reshape(len(actions), -1).all(axis=1)
    if bad.any():
        member = int(np.argmax(bad))
        task = getattr(venv, "task", None)
        where = (f"{task.scenario.preset.name} on {task.loop.paths[member].name}"
                 if task is not None else "its env")
        raise ValueError(f"policy {getattr(policy, 'name', type(policy).__name__)!r} returned "
                         f"a non-finite action {actions[member].tolist()} at step {step} of "
                         f"member {member} ({where})")
    return actions


def run_policy(
    env_id_or_kwargs: EnvSpec, policy: Policy, *, seed: int = 0, **env_kwargs: Any
) -> dict[str, Any]:
    """Run one episode of the env with ``policy`` to its end (see :func:`run_policy_batch`).

    Returns:
        The episode's ``info["metrics"]`` (``cycle_time`` s, ``max_contour_error`` m,
        ``finished``, ...) plus ``return``, ``failed``, ``truncated``, ``steps`` and
        ``tolerance`` (m), as Python floats, ints and bools.

    >>> from agents.policies import make_policy
    >>> m = run_policy("contour_gym/Feedrate-Corner-v0", make_policy("cnc_lookahead", mode="G61"))
    >>> m["finished"], m["max_contour_error"] <= m["tolerance"]
    (True, True)
    """
    batch = run_policy_batch(env_id_or_kwargs, policy, num_envs=1, seed=seed, **env_kwargs)
    return _episode(batch, 0)


def evaluate(
    policy: Policy | str, env: EnvSpec | gym.Env[Any, Any] | gym.vector.VectorEnv,
    n_episodes: int = 1, seed: int = 0,
) -> dict[str, Any]:
    """Run ``n_episodes`` episodes of ``policy`` to their ends and average their metrics.

    The episodes are the members of native vector envs of at most :data:`EVAL_ROUND` members,
    one round after another (:func:`run_policy_batch`; episode i is seeded ``seed + i``, so it
    equals ``run_policy(env, policy, seed=seed + i)``, whatever the round).

    Args:
        policy: A policy, or a registered policy's name (made with its default parameters
            by :func:`agents.policies.make`).
        env: A registered id, or a dict ``{"id": id, **env kwargs}``; or an env you made
            (as stable-baselines3's ``evaluate_policy`` takes one): a contour_gym env, single
            (wrappers allowed) or native vector, built with the arguments the policy needs
            (its ``env_kwargs``). A single env runs the episodes one after another, a vector
            env in rounds of its members; episode i is seeded ``seed + i`` either way.
        n_episodes: Episodes (members), >= 1.
        seed: Seed of the first episode.

    Returns:
        Every key :func:`run_policy` returns (the episode's ``info["metrics"]``:
        ``cycle_time`` s, ``max_contour_error`` m, ``finished``, ...; plus ``return``,
        ``failed``, ``truncated``, ``steps``, ``tolerance``) as the mean over the episodes, a
        float (booleans as the fraction of episodes; a ``cycle_time`` of ``inf``, an episode
        that did not arrive, makes the mean ``inf``), and ``"episodes"``: the episodes' own
        dicts, as :func:`run_policy` returns them (:class:`Episodes`, a sequence).

    Raises:
        ValueError: for ``n_episodes`` < 1 or more than the memory holds, an unknown policy
            name, an env that is not built as the policy needs (naming the argument); see
            :func:`env_arguments`.

    >>> m = evaluate("constant_feedrate", "contour_gym/Feedrate-Corner-v0", n_episodes=2)
    >>> len(m["episodes"]), m["finished"], m["max_contour_error"] <= m["tolerance"]
    (2, 1.0, True)
    """
    if isinstance(n_episodes, bool) or not isinstance(n_episodes, int) or n_episodes < 1:
        raise ValueError(f"n_episodes must be a positive int, got {n_episodes!r}")
    check_size(n_episodes * EPISODE_BYTES, f"the results of {n_episodes} episodes", "n_episodes")
    if isinstance(policy, str):
        policy = make(policy)
    if isinstance(env, (gym.Env, gym.vector.VectorEnv)):
        rounds = _rounds_on_instance(env, policy, n_episodes, seed)
    else:
        rounds = ((first, run_policy_batch(env, policy, seed=seed + first,
                                           num_envs=min(EVAL_ROUND, n_episodes - first)))
                  for first in range(0, n_episodes, EVAL_ROUND))
    batch = _gathered(rounds, n_episodes)
    out: dict[str, Any] = {key: float(np.mean(value)) for key, value in batch.items()}
    out["episodes"] = Episodes(batch)
    return out


def _gathered(
    rounds: Iterator[tuple[int, dict[str, NDArray[Any]]]], n: int
) -> dict[str, NDArray[Any]]:
    # the rounds' arrays (episodes first:first + len) into one array (n,) per key
    out: dict[str, NDArray[Any]] = {}
    for first, batch in rounds:
        for key, value in batch.items():
            if key not in out:
                out[key] = np.empty(n, dtype=value.dtype)
            part = value[: n - first]
            out[key][first : first + len(part)] = part
    return out


class Episodes(Sequence[dict[str, Any]]):
    """Each episode's values of an evaluation (:func:`evaluate`), a dict made when read.

    Held as one array per key (not a dict per episode), so that a long evaluation's results
    stay small; compares equal to the list of the same dicts.
    """

    def __init__(self, batch: Mapping[str, NDArray[Any]]) -> None:
        self._batch = batch
        self._n = len(next(iter(batch.values()))) if batch else 0

    def __len__(self) -> int:
        return self._n

    @overload
    def __getitem__(self, i: int) -> dict[str, Any]: ...

    @overload
    def __getitem__(self, i: slice) -> list[dict[str, Any]]: ...

    def __getitem__(self, i: int | slice) -> dict[str, Any] | list[dict[str, Any]]:
        if isinstance(i, slice):
            return [self[k] for k in range(*i.indices(self._n))]
        if not -self._n <= i < self._n:
            raise IndexError(f"episode {i} of {self._n}")
        return _episode(self._batch, i % self._n)

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Sequence) and list(self) == list(other)

    __hash__ = None  # type: ignore[assignment]

    def __repr__(self) -> str:
        return f"Episodes({self._n} episodes)"


def _rounds_on_instance(
    env: gym.Env[Any, Any] | gym.vector.VectorEnv, policy: Policy, n: int, seed: int
) -> Iterator[tuple[int, dict[str, NDArray[Any]]]]:
    # n episodes on a user's env: a native vector env in rounds of its members, a single env
    # as a vector env of one (both seeded seed + i for episode i); (first episode, arrays)
    unwrapped: Any = env.unwrapped
    config = getattr(unwrapped, "config", None)
    if config is None:
        raise ValueError(f"expected a contour_gym env, got {type(unwrapped).__name__}")
    for key, value in policy.env_kwargs.items():
        have = getattr(config, key)
        if have is None and key == "feedrate_override":  # None: the scenario's
            have = unwrapped.task.scenario.feed_override
        if not _same(have, value):
            raise ValueError(f"policy {policy.name!r} needs the env built with {key}={value!r}; "
                             f"the env has {key}={have!r}")
    venv = env if isinstance(env, gym.vector.VectorEnv) else _OneMember(env)
    for first in range(0, n, venv.num_envs):
        yield first, run_episodes(venv, policy, seed=seed + first)[0]


class _OneMember(gym.vector.VectorEnv):
    """A single contour_gym env seen as a vector env of one member (batched arrays)."""

    def __init__(self, env: gym.Env[Any, Any]) -> None:
        self.env, self.num_envs = env, 1
        self.single_observation_space = env.observation_space
        self.single_action_space = env.action_space
        self.observation_space = gym.vector.utils.batch_space(env.observation_space, 1)
        self.action_space = gym.vector.utils.batch_space(env.action_space, 1)
        self.task = cast(Any, env.unwrapped).task  # what run_episodes reads (its loop, ...)
        self.config = cast(Any, env.unwrapped).config  # what policies check at reset

    @property
    def unwrapped(self) -> Any:
        return self

    def reset(self, *, seed: Any = None, options: Any = None) -> tuple[Any, dict[str, Any]]:
        obs, info = self.env.reset(seed=seed, options=options)
        return _batched(obs), info

    def step(self, actions: Any) -> tuple[Any, ...]:
        obs, reward, terminated, truncated, info = self.env.step(np.asarray(actions)[0])
        if terminated or truncated:  # the vector env's info of an ending member
            info = {**info, "metrics": _batched(info["metrics"])}
        batched = {**info, "failure": np.array([info["failure"]])}
        return (_batched(obs), np.array([reward]), np.array([terminated]),
                np.array([truncated]), batched)


def _batched(values: Mapping[str, Any]) -> dict[str, Any]:
    # one member's values with a leading batch axis of 1
    return {k: _batched(v) if isinstance(v, Mapping) else np.asarray(v)[None]
            for k, v in values.items()}


def _episode(batch: Mapping[str, NDArray[Any]], i: int) -> dict[str, Any]:
    # member i's values as Python floats, ints and bools
    return {key: value[i].item() for key, value in batch.items()}
