"""Train and export the shipped agents of ``configs/rl/shipped.yml`` into ``agents/trained``.

``python -m agents.rl.train_shipped NAME [NAME ...]`` (``--list`` lists the names) trains each
agent with :func:`agents.rl.train.train` from its entry::

    ppo_ccc_circle:
      algo: ppo
      env_id: contour_gym/CCC-Circle-v0
      seed: 0
      timesteps: 1000000           # optional: the config's n_timesteps
      env_kwargs: {randomize: true} # replace the config block's env_kwargs
      hyperparams: {n_epochs: 10}  # optional: replace the block's other keys
      eval_episodes: 16            # optional: episodes per evaluation (default 4)
      act_env_kwargs: {...}        # optional: the env it acts in differs from its training
                                   # env's in these (e.g. a stricter feedrate_limit)

into ``runs/shipped/`` (``--runs``) and exports the run (:func:`export_agent`) into
``agents/trained/NAME/`` (``--dest``): ``model.zip`` and ``vecnormalize.pkl`` of the run's best
evaluation (its final model if it has none), and ``meta.yaml`` with the command that
reproduces it. ``meta.yaml``'s ``env_kwargs`` are the env the agent acts in: the training
env's, updated with ``act_env_kwargs`` (the training env's are kept as ``trained_env_kwargs``).
"""

from __future__ import annotations

import argparse
import copy
import importlib.resources
import shlex
import shutil
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import yaml

from agents.rl.algorithms import ALGORITHMS
from agents.rl.saved import META_FILE, MODEL_FILE, STATS_FILE, TRAINED_DIR, file_digest
from agents.rl.train import (
    BEST_META,
    BEST_MODEL,
    BEST_STATS,
    finished,
    read_curve,
    run_name,
    train,
)
from contour_gym.files import write_atomically, write_text

ENTRY_KEYS = {"algo": str, "env_id": str, "seed": int, "timesteps": int, "env_kwargs": dict,
              "hyperparams": dict, "eval_episodes": int, "act_env_kwargs": dict}


def shipped_file() -> Path:
    """The shipped ``configs/rl/shipped.yml``."""
    return Path(str(importlib.resources.files("agents") / "configs" / "rl" / "shipped.yml"))


def load_shipped(path: str | Path | None = None) -> dict[str, dict[str, Any]]:
    """The entries of ``shipped.yml``, checked.

    Raises:
        ValueError: naming the file, the agent and the key, for an unknown key, a value of the
            wrong type or a missing ``algo`` or ``env_id``.
    """
    file = Path(path) if path is not None else shipped_file()
    data = yaml.safe_load(file.read_text(encoding="utf-8"))
    if not isinstance(data, dict):
        raise ValueError(f"{file}: must map agent names to entries")
    for name, entry in data.items():
        if not isinstance(entry, dict):
            raise ValueError(f"{file}: {name}: must be a mapping")
        for key, value in entry.items():
            kind = ENTRY_KEYS.get(key)
            if kind is None:
                raise ValueError(f"{file}: {name}: unknown key {key!r}; accepted: "
                                 f"{', '.join(ENTRY_KEYS)}")
            if not isinstance(value, kind) or isinstance(value, bool):
                raise ValueError(f"{file}: {name}: {key} must be a {kind.__name__}, got {value!r}")
        missing = [k for k in ("algo", "env_id") if k not in entry]
        if missing or entry["algo"] not in ALGORITHMS:
            raise ValueError(f"{file}: {name}: needs algo (one of {', '.join(ALGORITHMS)}) and "
                             f"env_id, got {entry}")
    return data


def train_shipped(
    name: str,
    runs: str | Path = "runs/shipped",
    dest_root: str | Path = TRAINED_DIR,
    progress: bool = True,
    overwrite: bool = False,
) -> Path:
    """Train the shipped agent ``name`` and export it into ``dest_root/name``; returns that.

    Raises:
        ValueError: for an unknown name (listing the shipped ones), or an agent folder that
            holds a trained agent already (unless ``overwrite``), before any training; see
            :func:`train`.
    """
    entries = load_shipped()
    if name not in entries:
        raise ValueError(f"unknown shipped agent {name!r}; accepted: {', '.join(entries)}")
    dest = Path(dest_root) / name
    if (dest / MODEL_FILE).exists() and not overwrite:
        raise ValueError(f"{dest} holds a trained agent; pass --overwrite to replace it")
    entry = entries[name]
    overrides = {**entry.get("hyperparams", {})}
    if "env_kwargs" in entry:
        overrides["env_kwargs"] = entry["env_kwargs"]
    command = f"python -m agents.rl.train_shipped {shlex.quote(name)}"
    folder = Path(runs) / name
    run = folder / run_name(entry["env_id"], entry["algo"], entry.get("seed", 0))
    if not (run / "args.yml").exists():
        run = train(entry["env_id"], entry["algo"], entry.get("timesteps"),
                    seed=entry.get("seed", 0), out_dir=folder, progress=progress,
                    eval_episodes=entry.get("eval_episodes", 4), command=command,
                    **overrides)
    elif not finished(run):  # an interrupted or killed run: on from its last checkpoint
        run = train(resume=run, progress=progress)
    return export_agent(run, dest, command, entry.get("act_env_kwargs"))


def export_agent(run: Path, dest: Path, command: str,
                 act_env_kwargs: Mapping[str, Any] | None = None) -> Path:
    """Copy a finished run's model and statistics into the agent folder ``dest`` with a meta file.

    Args:
        run: The run folder (:func:`agents.rl.train.train`'s).
        dest: The agent folder (created; files replaced).
        command: The command that reproduces the agent (written to ``meta.yaml``).
        act_env_kwargs: Env arguments the agent acts with instead of its training env's
            (``meta.yaml``'s ``env_kwargs`` are then the training env's updated with them,
            and ``trained_env_kwargs`` the training env's).

    Raises:
        ValueError: for a run without ``model.zip``.
    """
    model = run / MODEL_FILE
    if not model.is_file():
        raise ValueError(f"cannot export {run}: {model} is missing")
    args = yaml.safe_load((run / "args.yml").read_text(encoding="utf-8"))
    block = yaml.safe_load((run / "config.yml").read_text(encoding="utf-8"))[args["env_id"]]
    dest.mkdir(parents=True, exist_ok=True)
    best = (run / BEST_MODEL).is_file()  # the best evaluation's model, else the final one
    pairs = ((BEST_MODEL, MODEL_FILE), (BEST_STATS, STATS_FILE)) if best else (
        (MODEL_FILE, MODEL_FILE), (STATS_FILE, STATS_FILE))
    for src, file in pairs:  # each whole or not at all; none left of an earlier export
        if (run / src).is_file():
            _copy_atomically(run / src, dest / file)
        else:
            (dest / file).unlink(missing_ok=True)
    curve = read_curve(run / "eval.csv")
    selected = yaml.safe_load((run / BEST_META).read_text(encoding="utf-8")) if best else None
    trained = block.get("env_kwargs") or {}
    meta = {"algo": args["algo"], "env_id": args["env_id"],
            "env_kwargs": {**trained, **(act_env_kwargs or {})}, "seed": args["seed"],
            "total_timesteps": args["total_timesteps"], "command": command,
            "selected_evaluation": selected,
            "last_evaluation": curve[-1] if curve else None}
    if act_env_kwargs:
        meta["trained_env_kwargs"] = copy.deepcopy(trained)  # no YAML anchors
    meta["files"] = {file: file_digest(dest / file) for _, file in pairs
                     if (dest / file).is_file()}
    write_text(dest / META_FILE, yaml.safe_dump(meta, sort_keys=False))
    return dest


def _copy_atomically(src: Path, target: Path) -> None:
    def copy(tmp: str) -> None:
        shutil.copyfile(src, tmp)

    write_atomically(target, copy)


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m agents.rl.train_shipped NAME [NAME ...]``."""
    parser = argparse.ArgumentParser(prog="python -m agents.rl.train_shipped",
                                     description=__doc__.splitlines()[0])
    parser.add_argument("names", nargs="*", metavar="NAME", help="agents of shipped.yml")
    parser.add_argument("--list", action="store_true", help="list the shipped agents")
    parser.add_argument("--runs", default="runs/shipped", help="parent of the run folders")
    parser.add_argument("--dest", default=str(TRAINED_DIR), help="parent of the agent folders")
    parser.add_argument("--overwrite", action="store_true",
                        help="replace agents already trained in --dest")
    args = parser.parse_args(argv)
    if args.list or not args.names:
        for name, entry in load_shipped().items():
            print(f"{name}: {entry['algo']} on {entry['env_id']}")
        return 0
    for name in args.names:
        dest = train_shipped(name, args.runs, args.dest, overwrite=args.overwrite)
        print(f"{name}: exported to {dest}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
