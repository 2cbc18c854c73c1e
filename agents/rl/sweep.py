"""Several training runs at once: seeds, algorithms and hyperparameter grids, local or on Ray.

``contour-gym train ENV_ID --seeds 0,1,2 [--algo ppo,sac] [--sweep learning_rate=1e-4,3e-4]``
trains every combination (a *trial*: one :func:`agents.rl.train.train` run) in parallel: on
``--workers`` processes of this machine (default every CPU), or with ``--ray ADDRESS`` as Ray
Tune trials on a cluster. Each trial writes the run folder :func:`~agents.rl.train.train` writes
(``<out>/<run name>``, or ``<out>/<key=value,...>/<run name>`` for a swept setting), so a trial
is the same run wherever it ran: the same seed gives the same weights, bit for bit.

A trial whose folder already holds a finished run is not trained again; one with a checkpoint
resumes from it (a trial whose Ray node died is retried, up to
:data:`agents.parallel.RAY_RETRIES` times, and continues from its last checkpoint); so running
the same sweep again after an interruption finishes only what was left.
"""

from __future__ import annotations

import itertools
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from agents.parallel import RAY_RETRIES, RayRunner, _init_worker, runner
from contour_gym.machines import plant_of


@dataclass(frozen=True)
class Trial:
    """One training run of a sweep.

    Attributes:
        env_id: The registered env id.
        algo: The algorithm.
        seed: The run's seed.
        overrides: Config keys replacing the block's (the swept values).
        out_dir: The folder its run folder goes in.
        timesteps: Env steps (None: the config's).
        config_file: The rl-zoo YAML (None: the shipped one).
        plant: The machine to train on instead of the id's (:func:`agents.rl.train.train`'s
            ``plant``; None: the id's).
    """

    env_id: str
    algo: str
    seed: int
    overrides: dict[str, Any] = field(default_factory=dict)
    out_dir: str = "runs"
    timesteps: int | None = None
    config_file: str | None = None
    plant: Any = None

    @property
    def run(self) -> Path:
        """The trial's run folder."""
        from agents.rl.train import run_name

        machine = None if self.plant is None else plant_of(self.plant)[1]
        return Path(self.out_dir) / run_name(self.env_id, self.algo, self.seed, machine)


def parse_grid(items: Sequence[str]) -> dict[str, list[Any]]:
    """``["KEY=V1,V2", ...]`` -> ``{KEY: [V1, V2]}``: numbers as numbers, the rest as YAML.

    Raises:
        ValueError: for an item without ``=`` or a value, or a key given twice.
    """
    grid: dict[str, list[Any]] = {}
    for item in items:
        key, sep, values = item.partition("=")
        key = key.strip()
        if not sep or not key or not values.strip():
            raise ValueError(f"a sweep is KEY=VALUE[,VALUE...], got {item!r}")
        if key in grid:
            raise ValueError(f"sweep key {key!r} given twice")
        grid[key] = [_value(v.strip()) for v in values.split(",")]
    return grid


def _value(text: str) -> Any:
    # a number as Python reads it (YAML 1.1 reads 1e-4 as a string), else the YAML value
    for kind in (int, float):
        try:
            return kind(text)
        except ValueError:
            pass
    return yaml.safe_load(text)


def trials(
    env_id: str, algos: Sequence[str], seeds: Sequence[int], grid: Mapping[str, Sequence[Any]],
    out_dir: str | Path = "runs", timesteps: int | None = None,
    config_file: str | Path | None = None, plant: Any = None,
) -> list[Trial]:
    """Every combination of algorithm, swept values and seed (in that nesting order).

    A combination of swept values trains under ``<out_dir>/<key=value,...>``.

    Raises:
        ValueError: for no algorithm or seed, or a seed given twice.
    """
    if not algos or not seeds:
        raise ValueError("a sweep needs at least one algorithm and one seed")
    if len(set(seeds)) != len(seeds):
        raise ValueError(f"seeds repeat: {list(seeds)}")
    keys = list(grid)
    out = []
    for algo in algos:
        for values in itertools.product(*(grid[k] for k in keys)):
            overrides = dict(zip(keys, values, strict=True))
            label = ",".join(f"{k}={v}" for k, v in overrides.items())
            folder = Path(out_dir) / label if label else Path(out_dir)
            out += [Trial(env_id, algo, int(s), overrides, str(folder), timesteps,
                          None if config_file is None else str(config_file), plant)
                    for s in seeds]
    return out


def run_trial(trial: Trial) -> str:
    """Train one trial (any process): skipped when finished, resumed from a checkpoint.

    Returns:
        The run folder.
    """
    from agents.rl.train import finished, latest_checkpoint, train

    run = trial.run
    if (run / "args.yml").is_file() and finished(run):
        return str(run)
    if (run / "args.yml").is_file() and latest_checkpoint(run) is not None:
        return str(train(resume=run, progress=False))
    if (run / "args.yml").is_file():  # started, no checkpoint yet: nothing to keep
        (run / "args.yml").unlink()
    return str(train(trial.env_id, trial.algo, trial.timesteps, seed=trial.seed,
                     out_dir=trial.out_dir, config_file=trial.config_file, progress=False,
                     plant=trial.plant, **trial.overrides))


def run_trials(
    todo: Sequence[Trial], workers: int | None = None, ray: str | None = None
) -> list[Path]:
    """Train every trial: on ``workers`` processes, or as Ray Tune trials on cluster ``ray``.

    Returns:
        The run folders, in the order of ``todo``.

    Raises:
        ValueError: for a bad ``workers``, ``ray`` without Ray installed, or a trial's own
            error (the first one; the other trials finish first).
    """
    if ray is not None:
        return _ray_tune(todo, ray, workers)
    folders: list[Path | None] = [None] * len(todo)
    with runner(min(len(todo), workers) if workers else None) as where:
        for i, folder in where.map(run_trial, list(todo)):
            folders[i] = Path(folder)
    return [f for f in folders if f is not None]


def _ray_tune(todo: Sequence[Trial], address: str, workers: int | None) -> list[Path]:
    """The trials as a Ray Tune grid (one CPU each), every trial's result its run folder."""
    cluster = RayRunner(address, workers)  # first: it says how to install Ray if missing
    from ray import tune

    try:
        trainable = tune.with_resources(_RayTrial(list(todo)), {"cpu": 1})
        root = os.path.commonpath([str(Path(t.out_dir).resolve()) for t in todo]) if todo else "."
        storage = Path(root) / "ray_tune"  # beside the sweep's run folders
        tuner = tune.Tuner(
            trainable,
            param_space={"trial": tune.grid_search(list(range(len(todo))))},
            run_config=tune.RunConfig(
                name="sweep", storage_path=str(storage), verbose=0,
                failure_config=tune.FailureConfig(max_failures=RAY_RETRIES),
            ),
        )
        grid = tuner.fit()
        results = [grid[i] for i in range(len(grid))]
        errors = [r.error for r in results if r.error is not None]
        if errors:
            raise errors[0]
        runs = {int((r.config or {})["trial"]): Path((r.metrics or {})["run"]) for r in results}
    finally:
        cluster.close()
    return [runs[i] for i in range(len(todo))]


class _RayTrial:
    """A Ray Tune function trainable: trial ``config["trial"]`` trained, its folder reported."""

    def __init__(self, todo: list[Trial]) -> None:
        self.todo = [_absolute(t) for t in todo]
        self.__name__ = "contour_gym_train"

    def __call__(self, config: dict[str, Any]) -> None:
        from ray import tune

        _init_worker()
        folder = run_trial(self.todo[int(config["trial"])])
        tune.report({"run": folder, **_last_evaluation(Path(folder))})


def _absolute(trial: Trial) -> Trial:
    # Ray Tune runs a trial in a folder of its own: the run folders are given absolute
    fields = dict(trial.__dict__)
    fields["out_dir"] = str(Path(trial.out_dir).resolve())
    if trial.config_file is not None:
        fields["config_file"] = str(Path(trial.config_file).resolve())
    return Trial(**fields)


def _last_evaluation(run: Path) -> dict[str, float]:
    from agents.rl.train import read_curve

    rows = read_curve(run / "eval.csv") if (run / "eval.csv").is_file() else []
    return {k: float(v) for k, v in rows[-1].items()} if rows else {}
