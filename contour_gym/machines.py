"""Machine files: a preset with its own numbers, as YAML, usable wherever a plant is.

A machine file is what ``contour-gym identify`` writes for a twin of your machine, or what you
write by hand: the preset it starts from (its paths, controllers, CCC and limits) and the
fields it changes, as :func:`contour_gym.presets.resolve_preset` takes them in a dict::

    preset: xy_dc_servo          # the preset it overrides
    name: my_mill                # optional: the name reports and plots show
    stage:
      axes:
        x: {mass: 41.5, damping: 310.0, friction: {law: stribeck, fc: 2.1, fs: 2.9, vs: 0.004}}
        y: {mass: 27.0}
    axis_gains:
      x: {kp: 2400.0}
    identified:                  # optional, ignored when loading: what identify found
      ...

A ``friction`` mapping with a ``law`` key (a registered friction law: ``coulomb``,
``stribeck``, ``lugre``, ``none``) replaces the axis's friction model; without one it changes
fields of the model the preset has. Pass the file's path as ``plant=`` (``simulate``, envs,
suites) or ``--plant`` (the command line).
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import yaml

from contour_gym.files import write_text

SUFFIXES = (".yaml", ".yml")
NOT_LOADED = ("identified",)  # a machine file's keys that describe it, not the machine


def is_machine_file(plant: object) -> bool:
    """Whether ``plant`` names a machine file (a str or path ending in .yaml or .yml)."""
    return isinstance(plant, (str, Path)) and Path(plant).suffix.lower() in SUFFIXES


def read_machine(path: str | Path) -> dict[str, Any]:
    """The plant dict of a machine file (``{"preset": name, **overrides}``).

    Raises:
        ValueError: naming the file: missing, not YAML, not a mapping, or without a
            ``preset``.
    """
    source = Path(path)
    try:
        data = yaml.safe_load(source.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise ValueError(f"machine file {source} does not exist") from None
    except (OSError, UnicodeDecodeError, yaml.YAMLError) as exc:
        said = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise ValueError(f"machine file {source} cannot be read: {said}") from None
    if not isinstance(data, dict) or not isinstance(data.get("preset"), str):
        raise ValueError(f"machine file {source} must map 'preset' to the name of the preset "
                         "it overrides (and its fields to their new values)")
    return {k: v for k, v in data.items() if k not in NOT_LOADED}


def plant_of(plant: str | Path | Mapping[str, Any]) -> tuple[str | dict[str, Any], str]:
    """A plant as envs and scenarios take it, and its name: a machine file is read now.

    Args:
        plant: A preset name, a machine file's path, or a plant dict.

    Returns:
        ``(plant, name)``: the preset name or plant dict (a machine file's content, so that
        what ran is recorded whole), and the name reports and run folders use (the file's
        ``name``, else its stem; a dict's ``name``, else its ``preset``; characters other than
        letters, digits and ``_.+-`` become ``_``).
    """
    if is_machine_file(plant):
        data = read_machine(plant)  # type: ignore[arg-type]
        return data, _folder_safe(data.get("name") or Path(plant).stem)  # type: ignore[arg-type]
    if isinstance(plant, Mapping):
        return dict(plant), _folder_safe(plant.get("name") or plant.get("preset"))
    return str(plant), _folder_safe(plant)


def _folder_safe(name: object) -> str:
    # a name that can end a run folder's name: no separators, no dots alone, no spaces
    return re.sub(r"[^A-Za-z0-9_.+-]+", "_", str(name)).strip(".") or "machine"


def identified_of(plant: object) -> dict[str, Any]:
    """The ``identified`` record of a twin's machine file (what ``identify`` found).

    ``{}`` for a preset name, a plant dict, or a machine file without one.
    """
    if not is_machine_file(plant):
        return {}
    data = yaml.safe_load(Path(plant).read_text(encoding="utf-8"))  # type: ignore[arg-type]
    record = data.get("identified") if isinstance(data, dict) else None
    return record if isinstance(record, dict) else {}


def undetermined_of(plant: object) -> dict[str, list[str]]:
    """Per axis, the values a twin's machine file records its logs did not determine.

    ``{}`` for a preset name, a plant dict, or a machine file that ``identify`` did not write
    (its ``identified`` record says which values; :meth:`agents.twin.identified.Identified.reasons`
    says why).
    """
    found = identified_of(plant).get("undetermined")
    if not isinstance(found, dict):
        return {}
    return {str(axis): [str(n) for n in names] for axis, names in found.items()
            if isinstance(names, list) and names}


def write_machine(path: str | Path, plant: dict[str, Any], identified: Any = None) -> Path:
    """Write a machine file (whole or not at all) and return its path.

    Args:
        path: Where (``.yaml`` or ``.yml``).
        plant: ``{"preset": name, **overrides}`` of plain numbers, strings, lists and dicts.
        identified: What to record beside it under ``identified`` (not loaded back).

    Raises:
        ValueError: for another suffix or a plant without its ``preset``.
    """
    target = Path(path)
    if not is_machine_file(target):
        raise ValueError(f"a machine file's name ends in .yaml or .yml, got {target}")
    if not isinstance(plant.get("preset"), str):
        raise ValueError("a machine file's plant needs 'preset': the preset it overrides")
    data = dict(plant) if identified is None else {**plant, "identified": identified}
    write_text(target, yaml.safe_dump(data, sort_keys=False))
    return target


__all__ = ["SUFFIXES", "identified_of", "is_machine_file", "plant_of", "read_machine",
           "undetermined_of", "write_machine"]
