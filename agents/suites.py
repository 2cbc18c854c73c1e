"""Suites of the evaluation harness: YAML files of scenarios and policies, validated.

:func:`load_suite` reads and checks a suite for :mod:`agents.bench` (``contour-gym bench``).

**Suites** are YAML files (read with ``yaml.safe_load``); the shipped ones live in
``configs/suites`` (:func:`shipped_suites`: ``default`` covers every paper's scenario and every
reference policy; ``tiny`` is for tests). A suite::

    description: what it is for                # optional
    seeds: 1                                   # optional default of every scenario
    summary: paths                             # optional: add a per-path table by machine
                                               # (agents.generalization)
    policies:                                  # label -> policy (the labels name table rows)
      no_ccc:                                  # empty: the registered policy of that name
      pid_ccc:
      slow_feed:                               # a registered policy with parameters
        policy: constant_feedrate
        params: {override: 0.8}
      mine:                                    # your own controller: module:Class
        policy: my_controllers:GainScheduler
        params: {gain: 2.0}
    scenarios:                                 # name -> scenario (names the plots)
      000-circle:
        env: contour_gym/CCC-Circle-v0         # a registered id, -v0 or -v1 (prefix optional)
        baseline: no_ccc                       # the paper's baseline policy (a label)
        policies: [no_ccc, pid_ccc]            # optional: default every policy that fits
      my-part:
        task: ccc                              # ... or task + plant + path (CCC-v0 / Feedrate-v0)
        plant: xy_servo_coulomb                # a preset name or {preset: ..., stage: ...}
        path: corner                           # a library path name, or random (a new
                                               # path per seed; env_kwargs.path_options)
        # gcode: parts/bracket.nc              # ... or a G-code part instead of path (a file
                                               # relative to the suite's folder)
        estimator: ground_truth                # optional, as are axis_controller, ideal
        ideal: true                            # the papers' pure model (default: the rig)
        seeds: [0, 1, 2]                       # a count n (seeds 0..n-1) or a list
        env_kwargs: {decision_ticks: 20}       # any further env argument
        magnify: 500                           # optional: the contour plot's magnification
        baseline: pid_ccc

Policies are looked up by name in :mod:`agents.policies` (:func:`agents.policies.available`),
so a saved agent registered there appears in a suite by name. ``module:Class`` names your own
controller: a class with ``predict(obs)`` (stable-baselines3's signature; ``deterministic=True``
is passed when it takes it) that maps the env's *batched* ``Dict`` observation to actions
``(B, n)``, built with ``params`` as keyword arguments; optional attributes ``env_kwargs``
(env arguments it needs), ``tasks`` (``("ccc",)``, ``("feedrate",)``; default both) and a
method ``reset(env)``, called before each batch of episodes. The module is imported from
``sys.path`` or the suite file's folder. A :class:`~agents.policies.Policy` subclass is used
as is.

**Which policy runs where.** A policy runs on the scenarios of the env kinds it declares
(:attr:`agents.policies.Policy.tasks`): CCC policies on CCC ids, feedrate policies on feedrate
ids; a scenario's ``policies`` list narrows that (naming a policy of the other kind is an
error). As in :mod:`agents.evaluate`, a policy's own ``env_kwargs`` override the registered
id's defaults (``cnc_lookahead``'s G64 on ``Feedrate-Corner-v0``, whose id runs G61), so the
policy gets its own env; but what the *suite* sets for a scenario (``estimator``,
``axis_controller``, ``ideal``, ``plant``, ``path``, ``env_kwargs``) is the scenario: a policy
that needs it otherwise does not fit it, and its cell is *skipped* with the conflict as its
note (a table row, not an error; :func:`agents.bench.plan`), e.g. ``adaptive_fuzzy_pid_ccc``
(SMC+DOB axes) on a scenario that sets ``axis_controller: pid``. Policies needing the same env
arguments share one env.

Bad input raises ValueError naming the file and the key before any work starts: an unknown
suite name (listing the shipped ones), an unknown scenario env (listing the ids), an unknown
policy (listing the accepted ones) or policy label, an unknown key anywhere in the YAML, a
value of the wrong type (naming the key, the expected type and the value), a value the env or
the policy rejects.
"""

from __future__ import annotations

import functools
import hashlib
import importlib
import inspect
import json
import math
import os
import re
import sys
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, cast

import gymnasium as gym
import numpy as np
import yaml

import contour_gym  # noqa: F401  (registers the ids)
from agents.policies import Actions, Observation, Policy, available, make_policy
from contour_gym.contour.base import ESTIMATORS
from contour_gym.envs.config import EnvConfig
from contour_gym.envs.core import CCC, FEEDRATE
from contour_gym.envs.registration import ENV_IDS, SCENARIOS
from contour_gym.paths import NAMES as PATH_NAMES
from contour_gym.paths import GcodeError, GcodePath, from_gcode
from contour_gym.presets import resolve_preset
from contour_gym.servo.base import CONTROLLERS

SUITES_DIR = Path(__file__).resolve().parent / "configs" / "suites"
"""The shipped suites (``agents/configs`` links to the repository's ``configs``)."""

TASKS = {"ccc": CCC, "feedrate": FEEDRATE}  # suite spelling -> env kind
GENERIC_IDS = {CCC: "CCC-v0", FEEDRATE: "Feedrate-v0"}  # task + plant + path runs on these
ID_PREFIX = "contour_gym/"
RANDOM_PATH = "random"  # a scenario path drawn per episode (contour_gym.paths.random_path)
_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.+-]*$")  # labels and scenario names (file names)


@dataclass(frozen=True)
class PolicySpec:
    """A suite's policy: its table label, what to build and with which parameters.

    Attributes:
        label: The row's name in the tables and plots.
        target: A registered policy name, or ``module:Class``.
        params: Keyword arguments of the policy (or the class).
        search_dir: Folder tried for ``module:Class`` imports (the suite file's).
    """

    label: str
    target: str
    params: Mapping[str, Any] = field(default_factory=dict)
    search_dir: Path | None = None

    def build(self) -> Policy:
        """A new policy (a fresh one per cell: policies may keep state).

        Raises:
            ValueError: for an unknown policy (listing the accepted ones), a module or class
                that cannot be imported, an unknown parameter or a bad value.
        """
        if ":" not in self.target:
            return make_policy(self.target, **self.params)
        module_name, _, class_name = self.target.partition(":")
        with _importable(self.search_dir):
            try:
                module = importlib.import_module(module_name)
            except ImportError as exc:
                raise ValueError(f"cannot import module {module_name!r} of policy "
                                 f"{self.target!r}: {exc}") from None
        cls = getattr(module, class_name, None)
        if not isinstance(cls, type):
            raise ValueError(f"module {module_name!r} has no class {class_name!r} "
                             f"(policy {self.target!r})")
        try:
            obj = cls(**self.params)
        except TypeError as exc:
            raise ValueError(f"policy {self.target!r}: {exc}") from None
        return obj if isinstance(obj, Policy) else ControllerPolicy(obj)


@contextmanager
def _importable(folder: Path | None) -> Iterator[None]:
    """``folder`` first on ``sys.path`` for the duration (if given and not there yet)."""
    entry = None if folder is None else str(folder)
    added = entry is not None and entry not in sys.path
    if added:
        sys.path.insert(0, cast(str, entry))
    try:
        yield
    finally:
        if added:
            sys.path.remove(cast(str, entry))


class ControllerPolicy(Policy):
    """A user's controller (any object with ``predict``) as a :class:`~agents.policies.Policy`.

    ``act(obs)`` is ``predict(obs)`` (with ``deterministic=True`` when ``predict`` takes it;
    a returned ``(actions, state)`` tuple gives its actions); ``env_kwargs``, ``tasks`` and
    ``reset(env)`` are the controller's when it has them.

    Args:
        controller: The object.

    Raises:
        ValueError: for an object without a callable ``predict``.
    """

    name = "controller"

    def __init__(self, controller: Any) -> None:
        predict = getattr(controller, "predict", None)
        if not callable(predict):
            raise ValueError(f"{type(controller).__name__} has no predict(obs) method")
        self.controller = controller
        params = inspect.signature(predict).parameters.values()
        self._deterministic = any(
            p.name == "deterministic" or p.kind is inspect.Parameter.VAR_KEYWORD for p in params
        )
        self.tasks = tuple(getattr(controller, "tasks", (CCC, FEEDRATE)))  # type: ignore[misc]

    @property
    def env_kwargs(self) -> dict[str, Any]:
        """The controller's ``env_kwargs`` (a fresh dict; empty if it has none)."""
        return dict(getattr(self.controller, "env_kwargs", None) or {})

    def reset(self, env: Any = None) -> None:
        """Call the controller's ``reset(env)`` if it has one."""
        reset = getattr(self.controller, "reset", None)
        if callable(reset):
            reset(env)

    def act(self, obs: Observation) -> Actions:
        """The controller's ``predict(obs)`` actions as float64."""
        kwargs = {"deterministic": True} if self._deterministic else {}
        result = self.controller.predict(obs, **kwargs)
        actions = result[0] if isinstance(result, tuple) else result
        return np.asarray(actions, dtype=np.float64)


@dataclass(frozen=True)
class ScenarioSpec:
    """A suite's scenario.

    Attributes:
        name: Its name (table rows, plot files).
        env_id: The registered id it runs.
        task: ``"ccc"`` or ``"feedrate"`` (the env kind).
        kwargs: The env arguments the suite sets (on top of the id's own).
        seeds: The episodes' seeds.
        baseline: The label of the paper's baseline policy.
        policies: Labels of the policies that run on it, in table order.
        magnify: The contour plot's error magnification (None: automatic).
    """

    name: str
    env_id: str
    task: str
    kwargs: Mapping[str, Any]
    seeds: tuple[int, ...]
    baseline: str
    policies: tuple[str, ...]
    magnify: float | None = None

    def env_spec(self) -> dict[str, Any]:
        """``{"id": env_id, **kwargs}``, as :mod:`agents.evaluate` takes it."""
        return {"id": self.env_id, **self.kwargs}

    def seed_blocks(self) -> list[tuple[int, int]]:
        """(first seed, count) of each run of consecutive seeds: one vector env each."""
        blocks: list[tuple[int, int]] = []
        for s in self.seeds:
            if blocks and s == blocks[-1][0] + blocks[-1][1]:
                blocks[-1] = (blocks[-1][0], blocks[-1][1] + 1)
            else:
                blocks.append((s, 1))
        return blocks


@dataclass(frozen=True)
class Suite:
    """A parsed, validated suite.

    Attributes:
        name: The file's stem.
        source: The YAML file.
        description: Its ``description``.
        policies: Label -> policy.
        scenarios: The scenarios, in file order.
        digest: SHA-256 of the parsed content (canonical JSON) and of its G-code parts.
        text: The file's text.
        summary: ``"paths"``: the results end with a per-path summary by machine
            (:mod:`agents.generalization`); empty: none.
    """

    name: str
    source: Path
    description: str
    policies: Mapping[str, PolicySpec]
    scenarios: tuple[ScenarioSpec, ...]
    digest: str
    text: str
    summary: str = ""

    def scenario(self, name: str) -> ScenarioSpec:
        """The scenario called ``name`` (a name :meth:`load_suite` accepted)."""
        return next(sc for sc in self.scenarios if sc.name == name)


def shipped_suites() -> list[str]:
    """Names of the suites in :data:`SUITES_DIR` (``default``, ``tiny``, ...)."""
    return sorted(p.stem for p in SUITES_DIR.glob("*.yaml"))


def suite_file(name_or_path: str | os.PathLike[str]) -> Path:
    """The YAML file of a shipped suite's name, or a path to one.

    Raises:
        ValueError: for an unknown name (listing the shipped ones) or a missing file.
    """
    text = os.fspath(name_or_path)
    as_path = Path(text)
    if as_path.suffix in (".yaml", ".yml") or os.sep in text or as_path.is_file():
        if not as_path.is_file():
            raise ValueError(f"suite file {text!r} not found")
        return as_path
    if text not in shipped_suites():
        raise ValueError(f"unknown suite {text!r}; shipped: {', '.join(shipped_suites())} "
                         "(or give a path to a .yaml file)")
    return SUITES_DIR / f"{text}.yaml"


@functools.cache
def code_digest() -> str:
    """SHA-256 of this installation's code and data: every file of ``contour_gym`` and ``agents``.

    Beside a suite's :attr:`Suite.digest` it names what a bench run's cells were computed with:
    a run folder resumes only under the same code (:class:`agents.bench.RunFolder`).
    """
    digest = hashlib.sha256()
    for package in (Path(contour_gym.__file__).parent, Path(__file__).parent):
        files = (f for f in package.rglob("*") if f.is_file() and "__pycache__" not in f.parts)
        for file in sorted(files):
            digest.update(file.relative_to(package.parent).as_posix().encode() + b"\0")
            digest.update(file.read_bytes())
    return digest.hexdigest()


def load_suite(name_or_path: str | os.PathLike[str] = "default") -> Suite:
    """Read and validate a suite (a shipped name or a YAML path); nothing runs.

    Every policy is built once (checking its name and parameters) and every scenario's env
    arguments are checked, so a bad suite fails here, before any work.

    Raises:
        ValueError: naming the file and the key (see the module docstring).
    """
    path = suite_file(name_or_path)
    text = path.read_text(encoding="utf-8")
    try:
        raw = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise ValueError(f"{path}: not valid YAML: {exc}") from None
    return _SuiteReader(path).suite(raw, text)


def _type_name(value: Any) -> str:
    return type(value).__name__


class _SuiteReader:
    """Validates a suite's parsed YAML; every error names the file and the key's path."""

    SUITE_KEYS = ("description", "seeds", "summary", "policies", "scenarios")
    SUMMARIES = ("paths",)
    POLICY_KEYS = ("policy", "params")
    SCENARIO_KEYS = ("env", "task", "plant", "path", "gcode", "estimator", "axis_controller",
                     "ideal", "seeds", "env_kwargs", "baseline", "policies", "magnify")
    ENV_KEYS = ("plant", "path", "estimator", "axis_controller", "ideal")  # scenario -> env

    def __init__(self, path: Path) -> None:
        self.path = path
        self.parts: dict[str, str] = {}  # G-code file -> its text (the suite's identity)

    def error(self, where: str, message: str) -> ValueError:
        return ValueError(f"{self.path}: {where}: {message}")

    def mapping(self, value: Any, where: str, keys: Sequence[str] | None) -> dict[str, Any]:
        if not isinstance(value, dict):
            raise self.error(where, f"expected a mapping, got {value!r} ({_type_name(value)})")
        for key in value:
            if not isinstance(key, str):
                raise self.error(where, f"keys must be strings, got {key!r} ({_type_name(key)})")
            if keys is not None and key not in keys:
                raise self.error(where, f"unknown key {key!r}; accepted: {', '.join(keys)}")
        return value

    def typed(self, value: Any, where: str, kind: type | tuple[type, ...], expected: str) -> Any:
        if isinstance(value, bool) and bool not in (kind if isinstance(kind, tuple) else (kind,)):
            raise self.error(where, f"expected {expected}, got {value!r} (bool)")
        if not isinstance(value, kind):
            raise self.error(where, f"expected {expected}, got {value!r} ({_type_name(value)})")
        return value

    def name(self, value: str, where: str) -> str:
        if not _NAME.match(value):
            raise self.error(where, f"names must be letters, digits, '_', '.', '+', '-' "
                             f"(a file name), got {value!r}")
        return value

    def seeds(self, value: Any, where: str) -> tuple[int, ...]:
        expected = "an int >= 1 (a count) or a list of distinct ints >= 0"
        if isinstance(value, int) and not isinstance(value, bool) and value >= 1:
            return tuple(range(value))
        if isinstance(value, list) and value and len(set(value)) == len(value) and all(
            isinstance(s, int) and not isinstance(s, bool) and s >= 0 for s in value
        ):
            return tuple(value)
        raise self.error(where, f"expected {expected}, got {value!r} ({_type_name(value)})")

    # ------------------------------------------------------------------------- the file
    def suite(self, raw: Any, text: str) -> Suite:
        top = self.mapping(raw, "top level", self.SUITE_KEYS)
        for key in ("policies", "scenarios"):
            if key not in top:
                raise self.error("top level", f"missing key {key!r}")
        description = self.typed(top.get("description", ""), "description", str, "a string")
        summary = self.typed(top.get("summary", ""), "summary", str, "'paths'")
        if summary and summary not in self.SUMMARIES:
            raise self.error("summary", f"unknown summary {summary!r}; accepted: "
                             f"{', '.join(self.SUMMARIES)}")
        seeds = self.seeds(top.get("seeds", 1), "seeds")
        policies = self.policies(top["policies"])
        built = {label: self.build(spec) for label, spec in policies.items()}
        scenarios = self.mapping(top["scenarios"], "scenarios", None)
        if not scenarios:
            raise self.error("scenarios", "no scenario")
        specs = tuple(self.scenario(name, value, seeds, built)
                      for name, value in scenarios.items())
        canonical = json.dumps([raw, self.parts], sort_keys=True, default=str)
        return Suite(self.path.stem, self.path, description, policies, specs,
                     hashlib.sha256(canonical.encode()).hexdigest(), text, summary)

    def policies(self, raw: Any) -> dict[str, PolicySpec]:
        entries = self.mapping(raw, "policies", None)
        if not entries:
            raise self.error("policies", "no policy")
        out = {}
        for label, value in entries.items():
            where = f"policies.{label}"
            self.name(label, where)
            body = self.mapping({} if value is None else value, where, self.POLICY_KEYS)
            target = self.typed(body.get("policy", label), f"{where}.policy", str,
                                "a policy name or module:Class")
            params = self.mapping(body.get("params") or {}, f"{where}.params", None)
            out[label] = PolicySpec(label, target, dict(params), self.path.parent.resolve())
        return out

    def build(self, spec: PolicySpec) -> Policy:
        where = f"policies.{spec.label}"
        if ":" not in spec.target and spec.target not in available():
            raise self.error(where, f"unknown policy {spec.target!r}; accepted: "
                             f"{', '.join(available())}, or module:Class")
        try:
            return spec.build()
        except ValueError as exc:
            raise self.error(where, str(exc)) from None

    # --------------------------------------------------------------------- a scenario
    def scenario(
        self, name: str, raw: Any, seeds: tuple[int, ...], built: Mapping[str, Policy]
    ) -> ScenarioSpec:
        where = f"scenarios.{name}"
        self.name(name, where)
        body = self.mapping(raw, where, self.SCENARIO_KEYS)
        env_id, task, registered = self.env(body, where)
        kwargs = self.env_kwargs(body, where, registered)
        labels = self.scenario_policies(body, where, task, built)
        if "baseline" not in body:
            raise self.error(where, "missing key 'baseline' (the paper's baseline policy)")
        baseline = self.typed(body["baseline"], f"{where}.baseline", str, "a policy label")
        if baseline not in labels:
            raise self.error(f"{where}.baseline", f"{baseline!r} is not among the scenario's "
                             f"policies ({', '.join(labels)})")
        magnify = body.get("magnify")
        if magnify is not None:
            self.typed(magnify, f"{where}.magnify", (int, float), "a number > 0")
            if not (math.isfinite(magnify) and magnify > 0):
                raise self.error(f"{where}.magnify", f"expected a number > 0, got {magnify!r}")
        scenario_seeds = self.seeds(body["seeds"], f"{where}.seeds") if "seeds" in body else seeds
        return ScenarioSpec(name, env_id, task, kwargs, scenario_seeds, baseline, labels,
                            None if magnify is None else float(magnify))

    def env(self, body: dict[str, Any], where: str) -> tuple[str, str, dict[str, Any]]:
        """The id, the env kind and the id's registered kwargs."""
        task = None
        if "task" in body:
            spelled = self.typed(body["task"], f"{where}.task", str, "'ccc' or 'feedrate'")
            if spelled not in TASKS:
                raise self.error(f"{where}.task", f"unknown task {spelled!r}; accepted: "
                                 f"{', '.join(TASKS)}")
            task = TASKS[spelled]
        if "env" in body:
            given = self.typed(body["env"], f"{where}.env", str, "a registered env id")
            env_id = ID_PREFIX + given.removeprefix(ID_PREFIX)
            if env_id not in ENV_IDS:
                raise self.error(f"{where}.env", f"unknown env {given!r}; accepted: "
                                 f"{', '.join(ENV_IDS)}")
            # the scenario of a -v0 or -v1 id (the registry names its -v0 id)
            scenario = env_id.removeprefix(ID_PREFIX).rsplit("-v", 1)[0] + "-v0"
            kind = SCENARIOS[scenario][0].lower()
            if task is not None and task != kind:
                raise self.error(f"{where}.task", f"{body['task']!r} contradicts env {given!r} "
                                 f"(a {kind} env)")
            return env_id, kind, dict(gym.spec(env_id).kwargs)
        if task is None:
            raise self.error(where, "give 'env' (a registered id) or 'task' (with plant, path)")
        key = GENERIC_IDS[task]
        return ID_PREFIX + key, task, dict(SCENARIOS[key][1])

    def env_kwargs(
        self, body: dict[str, Any], where: str, registered: dict[str, Any]
    ) -> dict[str, Any]:
        extra = self.mapping(body.get("env_kwargs") or {}, f"{where}.env_kwargs", None)
        kwargs: dict[str, Any] = {}
        for key in self.ENV_KEYS:
            if key in body:
                if key in extra:
                    raise self.error(f"{where}.env_kwargs", f"{key!r} is also given as "
                                     f"{where}.{key}: give it once")
                kwargs[key] = self.env_value(key, body[key], f"{where}.{key}")
        if "gcode" in body:
            if "path" in body or "path" in extra:
                raise self.error(f"{where}.gcode", "give either 'gcode' or 'path'")
            kwargs["path"] = self.part(body["gcode"], f"{where}.gcode")
        kwargs.update(extra)
        try:
            EnvConfig.from_kwargs({**registered, **kwargs})
        except (TypeError, ValueError) as exc:
            raise self.error(f"{where}.env_kwargs" if extra else where, str(exc)) from None
        return kwargs

    def env_value(self, key: str, value: Any, where: str) -> Any:
        if key == "ideal":
            return self.typed(value, where, bool, "true or false")
        if key == "plant":
            self.typed(value, where, (str, dict), "a plant preset name or {preset: ..., ...}")
            self.registered(resolve_preset, value, where)  # unknown names and fields
            return value
        self.typed(value, where, str, f"a {key} name")
        if key == "path":
            if value != RANDOM_PATH and value not in PATH_NAMES:
                raise self.error(where, f"unknown path {value!r}; accepted: {RANDOM_PATH!r} "
                                 f"(random paths; env_kwargs.path_options) or one of "
                                 f"{', '.join(PATH_NAMES)}")
        else:
            self.registered(ESTIMATORS.get if key == "estimator" else CONTROLLERS.get, value,
                            where)
        return value

    def part(self, value: Any, where: str) -> GcodePath:
        """The G-code part in file ``value`` (relative to the suite's folder), named by it."""
        file = self.path.parent / self.typed(value, where, str, "a G-code file")
        try:
            text = file.read_text(encoding="utf-8", errors="replace")
        except OSError as exc:
            raise self.error(where, f"{file}: {exc.strerror or exc}") from None
        try:
            part = from_gcode(text, name=file.stem)
        except GcodeError as exc:
            raise self.error(where, f"{file}: line {exc.line}: {exc.message}") from None
        except ValueError as exc:
            raise self.error(where, f"{file}: {exc}") from None
        self.parts[value] = text
        return part

    def registered(self, get: Callable[[str], Any], value: str, where: str) -> None:
        try:
            get(value)
        except ValueError as exc:
            raise self.error(where, str(exc)) from None

    def scenario_policies(
        self, body: dict[str, Any], where: str, task: str, built: Mapping[str, Policy]
    ) -> tuple[str, ...]:
        if "policies" not in body:
            labels = tuple(label for label, p in built.items() if task in p.tasks)
            if not labels:
                raise self.error(where, f"no policy of the suite acts in {task} envs")
            return labels
        listed = self.typed(body["policies"], f"{where}.policies", list, "a list of labels")
        for i, label in enumerate(listed):
            self.typed(label, f"{where}.policies[{i}]", str, "a policy label")
            if label not in built:
                raise self.error(f"{where}.policies[{i}]", f"unknown policy {label!r}; the "
                                 f"suite's policies: {', '.join(built)}")
            if task not in built[label].tasks:
                raise self.error(f"{where}.policies[{i}]", f"policy {label!r} acts in "
                                 f"{'/'.join(built[label].tasks)} envs, the scenario is {task}")
        if not listed or len(set(listed)) != len(listed):
            raise self.error(f"{where}.policies", f"expected distinct labels, got {listed!r}")
        return tuple(listed)
