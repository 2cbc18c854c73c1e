"""Train stable-baselines3 agents (PPO, SAC, TD3) on the native vector envs.

:func:`train` reads the env id's block of ``configs/rl/<algo>.yml`` (rl-zoo's format,
:mod:`agents.rl.config`), checks it and the call before any work starts, and trains on
:class:`agents.rl.vec_env.NativeVecEnv` (``n_envs`` members in one array program), wrapped
in ``VecMonitor`` and, when the config says ``normalize``, ``VecNormalize``. A run folder
``<out_dir>/<Id>_<algo>_seed<N>`` holds:

| file | holds |
|---|---|
| ``config.yml`` | the resolved block (rl-zoo format, overrides applied) |
| ``args.yml`` | the call's arguments and the command that reproduces the run |
| ``model.zip`` | the model when training ends (or is interrupted) |
| ``vecnormalize.pkl`` | its VecNormalize statistics (normalised runs) |
| ``tensorboard/`` | TensorBoard logs (SB3's, and ``eval/*``) |
| ``eval.csv``, ``.png`` | the evaluation curve (every ``eval_every`` steps; below) |
| ``checkpoints/`` | ``model_<steps>_steps.zip``, its ``vecnormalize`` and ``replay_buffer`` |
| ``best_model.zip`` | the model at its best evaluation (highest mean return) so far |
| ``best_vecnormalize.pkl`` | its statistics; ``best.yml`` its step count and evaluation |

The evaluation runs one episode per member of a separate native vector env (the nominal
machine: no ``randomize``) with deterministic actions, and records the mean max and mean
contour error (um), the cycle time (s), the failed fraction and the mean return; its episodes
are the training env's (random paths stay random: every evaluation the same ``eval_episodes``
paths, none a test path). The model of the highest mean return so far is kept as
``best_model.zip`` (as rl-zoo's ``best_model``): :mod:`agents.rl.train_shipped` exports it, a
selection on those evaluation episodes. Checkpoints of off-policy algorithms keep their replay
buffer (same step count).

A progress bar (tqdm, on stderr) shows the steps and the latest evaluation. Ctrl-C
(KeyboardInterrupt) saves the model, its statistics and a checkpoint, then re-raises;
``train(resume=RUN_DIR)`` continues a run from its latest checkpoint with the step count
continued (the env restarts its episodes, and the generators are reseeded with
``seed + steps``, so a resumed run is reproducible but not bit-equal to an uninterrupted
one). The same arguments give the same run: the same weights, bit for bit (torch runs with
``torch_threads`` threads, 1 by default).
"""

from __future__ import annotations

import csv
import dataclasses
import inspect
import math
import pickle
import re
import sys
import time
import warnings
import zipfile
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import yaml
from stable_baselines3.common.callbacks import BaseCallback, CallbackList

import contour_gym  # noqa: F401  (registers the ids)
from agents._files import save_figure
from agents.evaluate import run_policy_batch
from agents.rl.algorithms import algorithm
from agents.rl.config import RunConfig, algo_class, dump_block, load_config
from agents.rl.observation import FLATTEN_WRAPPER
from agents.rl.saved import SB3Policy
from agents.rl.vec_env import make_native_vec_env
from contour_gym.files import (
    remove_temporaries,
    write_atomically,
    write_handle_atomically,
    write_text,
)
from contour_gym.limits import check_size
from contour_gym.machines import plant_of

EVAL_SEED = 1_000_000  # eval member i is seeded EVAL_SEED + seed + i (apart from training's)
EVAL_COLUMNS = ("timesteps", "max_contour_error_um", "mean_contour_error_um", "cycle_time_s",
                "failures", "mean_return", "wall_time_s")
EVAL_LABELS = {"max_contour_error_um": "max |contour error| (um), mean",
               "mean_contour_error_um": "mean |contour error| (um), mean",
               "cycle_time_s": "cycle time (s), mean", "failures": "failed episodes (fraction)",
               "mean_return": "return, mean"}
_CHECKPOINT = re.compile(r"model_(\d+)_steps\.zip")


def run_name(env_id: str, algo: str, seed: int, machine: str | None = None) -> str:
    """The run folder's name, e.g. ``CCC-Circle-v0_ppo_seed0``, ``..._on_my_mill_ppo_seed0``."""
    on = "" if machine is None else f"_on_{machine}"
    return f"{env_id.split('/')[-1]}{on}_{algo}_seed{seed}"


def train(
    env_id: str | None = None,
    algo: str = "ppo",
    total_timesteps: int | None = None,
    seed: int = 0,
    out_dir: str | Path = "runs",
    resume: str | Path | None = None,
    *,
    config_file: str | Path | None = None,
    eval_every: int | None = None,
    eval_episodes: int = 4,
    checkpoint_every: int | None = None,
    progress: bool = True,
    torch_threads: int = 1,
    command: str | None = None,
    plant: str | Mapping[str, Any] | None = None,
    **overrides: Any,
) -> Path:
    """Train (or resume) a run and return its folder (see the module docstring).

    Args:
        env_id: A registered id with a block in the config (not needed with ``resume``).
        algo: ``"ppo"``, ``"sac"`` or ``"td3"``.
        total_timesteps: Env steps over all members (None: the config's ``n_timesteps``;
            with ``resume``, the run's).
        seed: Seed of the agent and of the env's members (member i gets ``seed + i``).
        out_dir: Parent folder of the run folder.
        resume: A run folder to continue from its latest checkpoint (its own config, id,
            algo and seed; ``total_timesteps`` may raise its target).
        config_file: rl-zoo YAML (None: the shipped ``configs/rl/<algo>.yml``).
        eval_every: Env steps between evaluations (None: a tenth of the run).
        eval_episodes: Episodes (members of the eval vector env) per evaluation.
        checkpoint_every: Env steps between checkpoints (None: a fifth of the run).
        progress: Show the progress bar.
        torch_threads: torch's CPU threads (fixed, for reproducible weights).
        command: The command line to record (None: this call's repr).
        plant: Train on this machine (preset, machine file or plant dict); config.yml keeps it.
        **overrides: Keys replacing the config block's (``n_envs``, ``env_kwargs``, SB3
            constructor arguments, ...), checked as the file's are.

    Returns:
        The run folder.

    Raises:
        ValueError: for a bad config, call or run folder, before any work starts.
        KeyboardInterrupt: after saving the model, its statistics and a checkpoint.
    """
    if resume is not None:
        return _resume(Path(resume), total_timesteps, progress, torch_threads)
    if not isinstance(env_id, str):
        raise ValueError(f"env_id must be a registered id, got {env_id!r}")
    config, machine = _new_config(algo, env_id, config_file, overrides, total_timesteps, plant)
    args = _new_run_args(config, env_id, algo, seed, eval_every, eval_episodes, checkpoint_every)
    run = Path(out_dir) / run_name(env_id, algo, seed, machine)
    _check_new(run)
    _set_threads(torch_threads)
    model = _new_model(config, algo, seed, run)  # refuses bad hyperparameters: no folder yet
    _new_run_folder(run, config, args, command or _call_repr(args, config_file, overrides))
    _learn(model, run, config, args, args["total_timesteps"], progress)
    return run


def _new_config(
    algo: str, env_id: str, config_file: Any, overrides: Mapping[str, Any],
    total_timesteps: int | None, plant: Any,
) -> tuple[RunConfig, str | None]:
    """A new run's config (on ``plant``'s machine when given) and that machine's name."""
    given = {} if total_timesteps is None else {"n_timesteps": total_timesteps}
    config = _within(load_config(algo, env_id, config_file, {**overrides, **given}))
    if plant is None:
        return config, None
    spec, machine = plant_of(plant)
    block = {**config.block, "env_kwargs": {**config.env_kwargs, "plant": spec}}
    return dataclasses.replace(config, block=block), machine


ON_POLICY_BATCH = 64  # PPO's batch size when its config gives none (SB3's default)


def _within(config: RunConfig) -> RunConfig:
    """The config, its rollout shortened to fit the run's timesteps (saying so).

    An on-policy algorithm collects ``n_steps`` per env before it stops, whatever the total:
    a run shorter than one rollout collects ``total // n_envs`` steps per env instead (at
    least 2), and its batch size fits in them (the whole rollout, unless the batch size divides
    it).
    """
    block, total, n_envs = config.block, config.n_timesteps, config.n_envs
    n_steps = block.get("n_steps")
    if n_steps is None or n_steps * n_envs <= total:
        return config
    steps = max(2, total // n_envs)
    new = {**block, "n_steps": steps}
    said = f"n_steps {steps}"
    if "batch_size" in block or config.algo == "ppo":
        rollout = steps * n_envs
        batch = min(int(block.get("batch_size", ON_POLICY_BATCH)), rollout)
        new["batch_size"] = batch if rollout % batch == 0 else rollout  # no truncated batch
        said += f", batch_size {new['batch_size']}"
    warnings.warn(f"{total} timesteps is less than one rollout ({n_steps} steps x {n_envs} "
                  f"envs): this run collects {steps} steps x {n_envs} envs ({said})",
                  stacklevel=2)
    return dataclasses.replace(config, block=new)


def _new_run_args(
    config: RunConfig, env_id: str, algo: str, seed: int, eval_every: int | None,
    eval_episodes: int, checkpoint_every: int | None,
) -> dict[str, Any]:
    """A new run's ``args.yml`` content (without its command), every value checked."""
    steps = config.n_timesteps
    return {
        "env_id": env_id, "algo": algo,
        "total_timesteps": _positive(steps, "total_timesteps"), "seed": _integer(seed, "seed"),
        "eval_every": _positive(eval_every or max(steps // 10, 1), "eval_every"),
        "eval_episodes": _positive(eval_episodes, "eval_episodes"),
        "checkpoint_every": _positive(checkpoint_every or max(steps // 5, 1), "checkpoint_every"),
    }


def _new_run_folder(run: Path, config: RunConfig, args: dict[str, Any], command: str) -> Path:
    """Make the run folder ``run``, write its ``config.yml`` and ``args.yml`` (with ``command``).

    Raises:
        ValueError: if the folder holds a run already (naming how to resume it).
    """
    _check_new(run)
    run.mkdir(parents=True, exist_ok=True)
    args["command"] = command
    write_text(run / "config.yml", dump_block(config))
    write_text(run / "args.yml", yaml.safe_dump(args, sort_keys=False))
    return run


def _check_new(run: Path) -> None:
    """Refuse a run folder that holds a run already, naming how to resume it."""
    if (run / "args.yml").exists():
        raise ValueError(f"run folder {run} exists; resume it (resume={str(run)!r}) or choose "
                         "another out_dir or seed")


def _new_model(config: RunConfig, algo: str, seed: int, run: Path) -> Any:
    """A fresh SB3 model of ``algo`` on the training env, logging into ``run``.

    Raises:
        ValueError: when the algorithm refuses its hyperparameters (naming them and why).
    """
    venv = make_training_env(config, seed)
    cls = algo_class(algo)
    kwargs = config.model_kwargs(_n_actions(venv))
    try:
        _check_buffer(cls, kwargs, venv)
    except ValueError:
        venv.close()
        raise
    try:
        return cls(env=venv, seed=seed, verbose=0, tensorboard_log=str(run / "tensorboard"),
                   device="cpu", **kwargs)
    except (AssertionError, ValueError, TypeError) as exc:  # SB3 checks by assert
        venv.close()
        said = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise ValueError(f"{algo} refuses its hyperparameters: {said}") from None


def _resume(run: Path, total_timesteps: int | None, progress: bool, threads: int) -> Path:
    args_file = run / "args.yml"
    if not args_file.is_file():
        raise ValueError(f"cannot resume {run}: {args_file} is missing")
    args = _run_args(args_file)
    config = load_config(args["algo"], args["env_id"], run / "config.yml")
    checkpoint = latest_checkpoint(run)
    if checkpoint is None:
        raise ValueError(f"cannot resume {run}: no checkpoint in {run / 'checkpoints'}")
    total = args["total_timesteps"] if total_timesteps is None else total_timesteps
    if total != args["total_timesteps"]:  # the run's target is now the new one
        args["total_timesteps"] = _positive(total, "total_timesteps")
        write_text(args_file, yaml.safe_dump(args, sort_keys=False))
    _set_threads(threads)
    try:
        model = load_checkpoint(run, config, checkpoint, args["seed"])
    except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile,
            pickle.UnpicklingError) as exc:
        raise ValueError(f"cannot resume {run}: {checkpoint} (or its statistics or buffer) "
                         f"cannot be loaded ({exc}); remove it to resume from the checkpoint "
                         "before") from None
    _forget_after(run / "eval.csv", model.num_timesteps)
    remove_temporaries(run)  # a killed run's half-written files (the run is this process's)
    _learn(model, run, config, args, _positive(total, "total_timesteps"), progress)
    return run


def _forget_after(path: Path, steps: int) -> None:
    """Drop ``eval.csv``'s rows past ``steps`` (the checkpoint resumed): none go back later."""
    if not path.is_file():
        return
    lines = path.read_text(encoding="utf-8").splitlines(keepends=True)
    kept = lines[:1] + [line for line in lines[1:] if float(line.split(",")[0]) <= steps]
    if len(kept) < len(lines):
        write_text(path, "".join(kept))


def _run_args(args_file: Path) -> dict[str, Any]:
    # a run's args.yml, read and checked (a damaged file is named, never a traceback)
    try:
        args = yaml.safe_load(args_file.read_text(encoding="utf-8"))
    except (OSError, yaml.YAMLError) as exc:
        raise ValueError(f"{args_file} cannot be read ({' '.join(str(exc).split())})") from None
    keys = ("algo", "env_id", "seed", "total_timesteps")
    if not isinstance(args, dict) or any(k not in args for k in keys):
        raise ValueError(f"{args_file} must map {', '.join(keys)} to the run's values")
    return args


def make_training_env(config: RunConfig, seed: int, venv_stats: Path | None = None) -> Any:
    """The training env: NativeVecEnv, VecMonitor and (when configured) VecNormalize.

    Args:
        config: The run's config.
        seed: Member i is seeded ``seed + i`` at the first reset.
        venv_stats: Saved VecNormalize statistics to continue from.

    Raises:
        ValueError: for a config with an ``env_wrapper`` other than ``FlattenObservation``
            (single-env wrappers do not apply to the native vector env, which flattens by
            itself; rl-zoo's trainer applies them).
    """
    from stable_baselines3.common.vec_env import VecMonitor, VecNormalize

    native = make_native_vec_env(config.env_id, config.n_envs, flatten=flattens(config),
                                 **config.env_kwargs)
    venv: Any = VecMonitor(native)
    venv.seed(seed)
    normalize = config.normalize
    if venv_stats is not None:
        venv = VecNormalize.load(str(venv_stats), venv)
        venv.training = True
    elif normalize is not None:
        venv = VecNormalize(venv, **normalize)
    return venv


def flattens(config: RunConfig) -> bool:
    """Whether the config's ``env_wrapper`` is :data:`~agents.rl.vec_env.FLATTEN_WRAPPER`.

    Raises:
        ValueError: for any other wrapper, naming the config file and the env id.
    """
    wrapper = config.block.get("env_wrapper")
    if wrapper is None or wrapper == FLATTEN_WRAPPER:
        return wrapper is not None
    raise ValueError(f"{config.source}: {config.env_id}: env_wrapper: contour-gym trains on the "
                     f"native vector env, which flattens the observation itself "
                     f"({FLATTEN_WRAPPER}) and takes no other single-env wrapper (rl_zoo3 "
                     f"does); got {wrapper!r}")


def _check_buffer(cls: Any, kwargs: Mapping[str, Any], venv: Any) -> None:
    """Refuse a rollout or replay buffer the memory cannot hold, before SB3 allocates it.

    A transition holds the observation (and a replay buffer the next one), the action and
    four scalars, as float32: ``n_steps`` x envs of them on-policy, ``buffer_size`` off-policy
    (the algorithm's defaults where the config gives none).
    """
    defaults = inspect.signature(cls).parameters
    obs = gym.spaces.flatdim(venv.observation_space)
    if "buffer_size" in defaults:
        rows = int(kwargs.get("buffer_size", defaults["buffer_size"].default))
        what, width, lower = f"a replay buffer of {rows} transitions", 2 * obs, "buffer_size"
    else:
        rows = int(kwargs.get("n_steps", defaults["n_steps"].default)) * venv.num_envs
        what, width, lower = f"a rollout of {rows} transitions", obs, "n_steps or n_envs"
    check_size(rows * 4.0 * (width + _n_actions(venv) + 4), what, lower)


def _n_actions(venv: Any) -> int:
    return int(np.prod(venv.action_space.shape))


def _learn(model: Any, run: Path, config: RunConfig, args: dict[str, Any], total: int,
           progress: bool) -> None:
    remaining = total - model.num_timesteps
    evals = EvalCurve(run, config, args["seed"], args["eval_every"], args["eval_episodes"])
    saver = Checkpoints(run, args["checkpoint_every"])
    bar = ProgressBar(total, model.num_timesteps, evals) if progress else None
    callbacks = CallbackList([c for c in (evals, saver, bar) if c is not None])
    try:
        if remaining > 0:
            model.learn(remaining, callback=callbacks, reset_num_timesteps=False,
                        tb_log_name=config.algo)
        evals.evaluate(model)  # the curve's last point, at the final step count
    except KeyboardInterrupt:
        save_checkpoint(model, run)
        save_final(model, run)
        raise
    finally:
        if bar is not None:
            bar.close()
    save_checkpoint(model, run)
    save_final(model, run)


def save_final(model: Any, run: Path) -> None:
    """``model.zip`` and (normalised runs) ``vecnormalize.pkl`` in the run folder.

    Each file is written whole or not at all, the statistics first: a run killed while it
    saves keeps its previous pair or no model (its checkpoints resume it).
    """
    normalizer = model.get_vec_normalize_env()
    if normalizer is not None:
        write_atomically(run / "vecnormalize.pkl", normalizer.save)
    write_handle_atomically(run / "model.zip", model.save)


BEST_MODEL, BEST_STATS, BEST_META = "best_model.zip", "best_vecnormalize.pkl", "best.yml"


def save_best(model: Any, run: Path, row: Mapping[str, float]) -> None:
    """The model of the best evaluation so far, its statistics and ``best.yml`` (``row``)."""
    normalizer = model.get_vec_normalize_env()
    if normalizer is not None:
        write_atomically(run / BEST_STATS, normalizer.save)
    write_handle_atomically(run / BEST_MODEL, model.save)
    text = yaml.safe_dump({k: float(v) for k, v in row.items()}, sort_keys=False)
    write_atomically(run / BEST_META, lambda tmp: Path(tmp).write_text(text, encoding="utf-8"))


def save_checkpoint(model: Any, run: Path) -> Path:
    """A checkpoint at the model's step count: model, VecNormalize stats, replay buffer.

    Each file is written whole or not at all, the model last: :func:`latest_checkpoint`
    finds checkpoints by their model, so a checkpoint a kill cut short is never found.
    """
    folder = run / "checkpoints"
    folder.mkdir(exist_ok=True)
    steps = model.num_timesteps
    normalizer = model.get_vec_normalize_env()
    if normalizer is not None:
        write_atomically(folder / f"vecnormalize_{steps}_steps.pkl", normalizer.save)
    if getattr(model, "replay_buffer", None) is not None:
        buffer = folder / f"replay_buffer_{steps}_steps.pkl"
        write_handle_atomically(buffer, model.save_replay_buffer)
    path = folder / f"model_{steps}_steps.zip"
    write_handle_atomically(path, model.save)
    return path


def finished(run: Path) -> bool:
    """Whether a run folder's training reached its step target (its last checkpoint did)."""
    checkpoint = latest_checkpoint(run)
    if checkpoint is None:
        return False
    return _steps(checkpoint) >= int(_run_args(run / "args.yml")["total_timesteps"])


def _steps(checkpoint: Path) -> int:
    # the step count in a checkpoint's name (model_<steps>_steps.zip)
    return int(_CHECKPOINT.fullmatch(checkpoint.name).group(1))  # type: ignore[union-attr]


def latest_checkpoint(run: Path) -> Path | None:
    """The checkpoint with the most steps in ``run/checkpoints`` (None: there is none)."""
    found = [(int(m.group(1)), p) for p in (run / "checkpoints").glob("model_*_steps.zip")
             if (m := _CHECKPOINT.fullmatch(p.name))]
    return max(found)[1] if found else None


def load_checkpoint(run: Path, config: RunConfig, checkpoint: Path, seed: int) -> Any:
    """The model of ``checkpoint`` on a new training env with its statistics and buffer.

    The generators (torch, numpy, the env's members) are reseeded with ``seed + steps``.
    """
    steps = _steps(checkpoint)
    stats = checkpoint.with_name(f"vecnormalize_{steps}_steps.pkl")
    venv = make_training_env(config, seed + steps, stats if stats.is_file() else None)
    model = algo_class(config.algo).load(checkpoint, env=venv, device="cpu",
                                         tensorboard_log=str(run / "tensorboard"))
    model.set_random_seed(seed + steps)
    buffer = checkpoint.with_name(f"replay_buffer_{steps}_steps.pkl")
    if algorithm(config.algo).off_policy and buffer.is_file():
        model.load_replay_buffer(buffer)
    return model


class Checkpoints(BaseCallback):
    """Saves a checkpoint (:func:`save_checkpoint`) every ``every`` env steps."""

    def __init__(self, run: Path, every: int) -> None:
        super().__init__()
        self.run, self.every = run, every
        self.next = 0

    def _on_training_start(self) -> None:
        self.next = (self.num_timesteps // self.every + 1) * self.every

    def _on_step(self) -> bool:
        if self.num_timesteps >= self.next:
            save_checkpoint(self.model, self.run)
            self.next = (self.num_timesteps // self.every + 1) * self.every
        return True


class EvalCurve(BaseCallback):
    """Evaluates every ``every`` env steps; appends to ``eval.csv``, redraws ``eval.png``.

    Each evaluation runs one episode per member of a native vector env of the training id
    and env kwargs less ``randomize`` (:func:`agents.evaluate.run_policy_batch`, member i
    seeded ``EVAL_SEED + seed + i``), acting deterministically on the observation normalised
    by the training statistics of the moment.
    """

    def __init__(self, run: Path, config: RunConfig, seed: int, every: int, episodes: int) -> None:
        super().__init__()
        self.run, self.config, self.seed = run, config, seed
        self.every, self.episodes = every, episodes
        self.next, self.started = 0, time.perf_counter()
        self.latest: dict[str, float] | None = None

    def _on_training_start(self) -> None:
        self.next = (self.num_timesteps // self.every + 1) * self.every

    def _on_step(self) -> bool:
        if self.num_timesteps >= self.next:
            row = self.evaluate(self.model)
            for key in EVAL_COLUMNS[1:-1]:
                self.logger.record(f"eval/{key}", row[key])
            self.next = (self.num_timesteps // self.every + 1) * self.every
        return True

    def evaluate(self, model: Any) -> dict[str, float]:
        """Evaluate ``model`` now (once per step count) and record the row."""
        rows = read_curve(self.run / "eval.csv")
        if rows and rows[-1]["timesteps"] == model.num_timesteps:
            self.latest = rows[-1]
            return rows[-1]
        row = self._row(model)
        if not any(r["mean_return"] >= row["mean_return"] for r in rows):
            save_best(model, self.run, row)
        append_row(self.run / "eval.csv", row)
        plot_curve(rows + [row], self.run / "eval.png", self.config.env_id, self.config.algo)
        self.latest = row
        return row

    def _row(self, model: Any) -> dict[str, float]:
        policy = SB3Policy(model, model.get_vec_normalize_env(), self.config.env_kwargs,
                           label=f"{self.config.algo} at {model.num_timesteps} steps")
        # the training env less its randomisation: random paths stay random, the reward its own
        kwargs = {k: v for k, v in self.config.env_kwargs.items() if k != "randomize"}
        out = run_policy_batch({"id": self.config.env_id, **kwargs}, policy,
                               num_envs=self.episodes, seed=EVAL_SEED + self.seed)
        return {
            "timesteps": model.num_timesteps,
            "max_contour_error_um": float(np.mean(out["max_contour_error"])) * 1e6,
            "mean_contour_error_um": float(np.mean(out["mean_contour_error"])) * 1e6,
            "cycle_time_s": float(np.mean(out["cycle_time"])),
            "failures": float(np.mean(out["failed"])),
            "mean_return": float(np.mean(out["return"])),
            "wall_time_s": time.perf_counter() - self.started,
        }


class ProgressBar(BaseCallback):
    """tqdm bar on stderr: env steps of the run, and the latest evaluation."""

    def __init__(self, total: int, start: int, evals: EvalCurve) -> None:
        from tqdm import tqdm

        super().__init__()
        self.evals, self.shown = evals, start
        self.bar = tqdm(total=total, initial=start, unit="step", file=sys.stderr,
                        dynamic_ncols=True, smoothing=0.1)

    def _on_step(self) -> bool:
        self.bar.update(self.num_timesteps - self.shown)
        self.shown = self.num_timesteps
        if self.evals.latest is not None:
            self.bar.set_postfix_str(format_eval(self.evals.latest), refresh=False)
        return True

    def close(self) -> None:
        """Close the bar."""
        self.bar.close()


def format_eval(row: Mapping[str, float]) -> str:
    """One line of an evaluation row (um, s)."""
    return (f"eval@{int(row['timesteps'])}: max {row['max_contour_error_um']:.3g} um, "
            f"mean {row['mean_contour_error_um']:.3g} um, cycle {row['cycle_time_s']:.3g} s, "
            f"fail {row['failures']:.0%}, return {row['mean_return']:.4g}")


def read_curve(path: Path) -> list[dict[str, float]]:
    """The rows of an ``eval.csv`` (empty when absent)."""
    if not path.is_file():
        return []
    with path.open(newline="") as f:
        return [{k: float(v) for k, v in row.items()} for row in csv.DictReader(f)]


def append_row(path: Path, row: Mapping[str, float]) -> None:
    """Append one row to ``eval.csv`` (the header first when the file is new)."""
    new = not path.is_file()
    with path.open("a", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=EVAL_COLUMNS)
        if new:
            writer.writeheader()
        writer.writerow({k: row[k] for k in EVAL_COLUMNS})


def plot_curve(rows: list[dict[str, float]], path: Path, env_id: str, algo: str) -> None:
    """The evaluation curve: one panel per metric against env steps."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt


    steps = [r["timesteps"] for r in rows]
    fig, axes = plt.subplots(2, 3, figsize=(11, 6), constrained_layout=True)
    for ax, key in zip(axes.flat, EVAL_COLUMNS[1:-1], strict=False):
        values = [r[key] if math.isfinite(r[key]) else np.nan for r in rows]
        ax.plot(steps, values, marker="o")
        ax.set_title(EVAL_LABELS[key])
        ax.set_xlabel("env steps")
        ax.grid(alpha=0.3)
    axes.flat[-1].axis("off")
    fig.suptitle(f"{algo} on {env_id}: evaluation (deterministic, nominal machine)")
    save_figure(fig, path)
    plt.close(fig)


def _set_threads(n: int) -> None:
    import torch

    torch.set_num_threads(_positive(n, "torch_threads"))


def _integer(value: Any, name: str) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise ValueError(f"{name} must be an integer, got {value!r}")
    return int(value)


def _positive(value: Any, name: str) -> int:
    if _integer(value, name) < 1:
        raise ValueError(f"{name} must be >= 1, got {value!r}")
    return int(value)


def _call_repr(args: Mapping[str, Any], config_file: Any, overrides: Mapping[str, Any]) -> str:
    keys = ("algo", "total_timesteps", "seed", "eval_every", "eval_episodes", "checkpoint_every")
    parts = [repr(args["env_id"])] + [f"{k}={args[k]!r}" for k in keys]
    if config_file is not None:
        parts.append(f"config_file={str(config_file)!r}")
    parts += [f"{k}={v!r}" for k, v in overrides.items()]
    return f"agents.rl.train.train({', '.join(parts)})"
