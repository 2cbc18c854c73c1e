"""Servo logs of real machines, read into SI arrays (seconds, metres): CSV and LinuxCNC halsampler.

A :class:`ServoLog` holds one time base and, per axis, the commanded and the measured position
(and, when logged, the drive's control signal and the commanded velocity). Read one with
:func:`read_log`; cut fit and held-out segments with :meth:`ServoLog.window`. :func:`write_csv`
and :func:`write_halsampler` write every digit of a float64: generated logs read back exactly.

**CSV**: a header row, then one row per sample, comma-separated: ``time`` (s) and, per axis,
``<axis>_cmd`` and ``<axis>_fb`` (both required), optionally ``<axis>_effort`` (the drive's
control signal, never scaled) and ``<axis>_vel_cmd``. An axis name is a letter then letters or
digits (``x``, ``y1``); names are read case-insensitively, a UTF-8 byte-order mark skipped.

**halsampler**: what LinuxCNC's ``halsampler`` prints from a ``sampler`` component: per servo
period a line of the pins' values (floats as ``%f``: six decimals of the machine unit), no
header; ``-t`` puts the sample number first; lost samples make it print a line ``overrun``.
``columns`` names the columns by HAL pin (:func:`read_halsampler`).

Lengths are in ``length_unit`` (:data:`LENGTH_UNITS`), converted to metres. Every refusal is a
:class:`LogError` naming the file, the line (as a text editor numbers it) and the column.
"""

from __future__ import annotations

import contextlib
import csv
import itertools
import os
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from contour_gym.files import write_text

__all__ = [
    "DEFAULT_JOINTS", "LENGTH_UNITS", "MIN_SAMPLES", "STILL_BELOW", "AxisLog", "LogError",
    "ServoLog", "encoder_step", "read_csv", "read_halsampler", "read_log", "write_csv",
    "write_halsampler",
]

MIN_SAMPLES = 100
"""Fewest samples a log may have (a tenth of a second at 1 kHz): fewer cannot fit an axis."""
STILL_BELOW = 1e-6
"""An axis whose command spans less than this (m, peak to peak) never moved
(:attr:`ServoLog.still`); a log in which no axis moved is refused."""
LENGTH_UNITS: dict[str, float] = {"m": 1.0, "mm": 1e-3, "inch": 0.0254}
"""The length units a log may be in, in metres each."""
DEFAULT_JOINTS = "xyzabcuvw"
"""The axis of joint 0, 1, 2, ... when a halsampler read is given no ``joints``."""

PathLike = str | os.PathLike[str]
Joints = str | Mapping[int, str] | None

_KINDS = ("cmd", "fb", "effort", "vel_cmd")
_AXIS = re.compile(r"[a-z][a-z0-9]*")
_PLAIN = re.compile(r"([a-z][a-z0-9]*)_(cmd|fb|effort|vel_cmd)")
_PIN = re.compile(r"(joint|pid)\.([a-z0-9]+)\.([a-z-]+)")
_JOINT_PINS = {"motor-pos-cmd": "cmd", "pos-cmd": "cmd", "motor-pos-fb": "fb", "pos-fb": "fb",
               "vel-cmd": "vel_cmd", "effort": "effort"}
_CSV_NAMES = ("time, <axis>_cmd, <axis>_fb, <axis>_effort or <axis>_vel_cmd (an axis name is a "
              "letter then letters or digits: x, y1, a)")
_PIN_NAMES = ("joint.N.motor-pos-cmd or joint.N.pos-cmd (cmd), joint.N.motor-pos-fb or "
              "joint.N.pos-fb (fb), joint.N.vel-cmd, pid.N.output or joint.N.effort (effort; "
              "pid.<axis>.output too), <axis>_cmd, <axis>_fb, <axis>_effort, <axis>_vel_cmd, "
              "or - to skip the column")
_TAG = "sample number"
# encoder_step: fewest moves to judge, the tolerance of a multiple (in steps), the divisors of
# the smallest move tried, the largest move in steps that float64 still resolves
_STEP_MIN_MOVES, _STEP_TOLERANCE, _STEP_DIVISORS, _STEP_MAX_COUNT = 20, 0.02, 16, 1e9

Layout = dict[str, dict[str, int]]  # axis -> kind -> column index


class LogError(ValueError):
    """A log that cannot be read (or written): a ValueError with a one-line message.

    It names the file, then the line (1-based, as an editor numbers it) and the column.

    Attributes:
        source: The file.
        message: What is wrong, without the place.
        line: 1-based line of the file, or None.
        column: ``"<number> (<name>)"`` of the column, or None.
    """

    def __init__(self, source: str, message: str, line: int | None = None,
                 column: str | None = None) -> None:
        where = source if line is None else f"{source}, line {line}"
        where += "" if column is None else f", column {column}"
        super().__init__(f"{where}: {message}".replace("\r", "\\r").replace("\n", "\\n"))
        self.source, self.message, self.line, self.column = source, message, line, column

    def __reduce__(self) -> tuple[Any, ...]:
        return (LogError, (self.source, self.message, self.line, self.column))


def _frozen(values: ArrayLike, what: str) -> NDArray[np.float64]:
    array = np.asarray(values, dtype=np.float64)
    if array.ndim != 1:
        raise ValueError(f"{what} must be one-dimensional, got shape {array.shape}")
    view = array.view()
    view.flags.writeable = False
    return view


@dataclass(frozen=True, eq=False)
class AxisLog:
    """One axis of a servo log: what it was told and what it did, one value per sample.

    Attributes:
        name: The machine's axis name (``"x"``, ``"y1"``, ...): a lowercase letter, then
            lowercase letters or digits.
        cmd: Commanded position, m.
        fb: Measured position, m.
        effort: The drive's control signal in the machine's own unit (not scaled), or None.
        vel_cmd: Commanded velocity, m/s, or None.
    """

    name: str
    cmd: NDArray[np.float64]
    fb: NDArray[np.float64]
    effort: NDArray[np.float64] | None = None
    vel_cmd: NDArray[np.float64] | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not _AXIS.fullmatch(self.name):
            raise ValueError(f"axis name {self.name!r}: a lowercase letter, then letters or "
                             "digits (x, y1, a)")
        for kind in _KINDS:
            values = getattr(self, kind)
            if values is not None:
                object.__setattr__(self, kind, _frozen(values, f"axis {self.name!r} {kind}"))
        sizes = {k: getattr(self, k).size for k in _KINDS if getattr(self, k) is not None}
        if len(set(sizes.values())) > 1:
            raise ValueError(f"axis {self.name!r}: its arrays differ in length: {sizes}")

    def _sliced(self, part: slice) -> AxisLog:
        cut = [None if (v := getattr(self, k)) is None else v[part] for k in _KINDS[2:]]
        return AxisLog(self.name, self.cmd[part], self.fb[part], *cut)


@dataclass(frozen=True, eq=False)
class ServoLog:
    """A servo log: the samples of one time base, per axis.

    Attributes:
        time: (N,) sample times, s, strictly increasing (N >= 2).
        axes: One :class:`AxisLog` per axis, each of N samples, names unique.
        source: The file it was read from (or any label).

    Example:
        >>> import numpy as np
        >>> t = np.arange(200) * 1e-3
        >>> log = ServoLog(t, (AxisLog("x", 0.01 * t, 0.01 * t),), "made")
        >>> log.names, round(log.period, 9), log.window(0.05, 0.1).time.size
        (('x',), 0.001, 50)
    """

    time: NDArray[np.float64]
    axes: tuple[AxisLog, ...]
    source: str = ""

    def __post_init__(self) -> None:
        time = _frozen(self.time, "time")
        object.__setattr__(self, "time", time)
        object.__setattr__(self, "axes", tuple(self.axes))
        if time.size < 2 or not np.all(np.diff(time) > 0):
            raise ValueError("time must hold 2 or more samples, strictly increasing")
        names = [a.name for a in self.axes]
        if not names or len(set(names)) != len(names):
            raise ValueError(f"a log needs one or more axes, names unique: got {names}")
        for axis in self.axes:
            if axis.cmd.size != time.size:
                raise ValueError(f"axis {axis.name!r} has {axis.cmd.size} samples, time "
                                 f"{time.size}")

    @property
    def names(self) -> tuple[str, ...]:
        """The axis names, in the log's order."""
        return tuple(a.name for a in self.axes)

    @property
    def period(self) -> float:
        """The median time step, s."""
        return float(np.median(np.diff(self.time)))

    @property
    def still(self) -> tuple[str, ...]:
        """The axes whose command never moved (spans under :data:`STILL_BELOW`)."""
        return tuple(a.name for a in self.axes if float(np.ptp(a.cmd)) < STILL_BELOW)

    @property
    def duration(self) -> float:
        """Time from the first sample to the last, s."""
        return float(self.time[-1] - self.time[0])

    def axis(self, name: str) -> AxisLog:
        """The axis named ``name``.

        Raises:
            ValueError: when the log has no such axis (the message names those it has).
        """
        for axis in self.axes:
            if axis.name == name:
                return axis
        raise ValueError(f"{self.source or 'the log'} has no axis {name!r}: its axes are "
                         f"{', '.join(self.names)}")

    def window(self, t0: float, t1: float) -> ServoLog:
        """The log of the samples with ``t0 <= time < t1`` (a fit or held-out segment).

        Raises:
            ValueError: when fewer than 2 samples lie in the window.
        """
        i0, i1 = np.searchsorted(self.time, [t0, t1], side="left")
        if i1 - i0 < 2:
            raise ValueError(f"window [{t0}, {t1}) s holds {max(i1 - i0, 0)} samples of "
                             f"{self.source or 'the log'} (its time spans {self.time[0]} to "
                             f"{self.time[-1]} s); a log needs 2 or more")
        part = slice(int(i0), int(i1))
        return ServoLog(self.time[part], tuple(a._sliced(part) for a in self.axes), self.source)


def _read_lines(path: PathLike) -> tuple[str, list[str]]:
    """The file's name and its lines (UTF-8, a byte-order mark skipped, ends of line dropped)."""
    source = os.fspath(path)
    raw = Path(path).read_bytes()
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as e:
        line = raw.count(b"\n", 0, e.start) + 1
        raise LogError(source, f"is not UTF-8 text (byte {raw[e.start]:#04x})", line) from None
    return source, (text.replace("\r\n", "\n") if "\r" in text else text).split("\n")


def _rows(lines: list[str], start: int) -> tuple[list[str], NDArray[np.int64]]:
    """The non-blank lines from ``start`` on, and their 1-based line numbers."""
    body = lines[start:]
    full = list(map(bool, map(str.strip, body)))
    linenos = np.flatnonzero(np.array(full, dtype=bool)).astype(np.int64) + start + 1
    return list(itertools.compress(body, full)), linenos


def _label(j: int, name: str) -> str:
    return f"{j + 1} ({name})"


def _fields(row: str, sep: str | None) -> list[str]:
    return next(csv.reader([row])) if sep else row.split()


def _parse(source: str, rows: list[str], linenos: NDArray[np.int64], names: list[str],
           sep: str | None, expect: str, used: Sequence[int]) -> NDArray[np.float64]:
    """The numbers of ``rows`` (:data:`MIN_SAMPLES` or more), ``len(names)`` a row, ``used`` finite.

    numpy reads them at once; when it cannot, the rows are read one by one to find the first
    bad one (or to read what Python's ``float`` reads and numpy does not).
    """
    data: NDArray[np.float64] | None = None
    with contextlib.suppress(ValueError):
        data = np.loadtxt(rows, dtype=np.float64, comments=None, delimiter=sep, ndmin=2,
                          quotechar='"' if sep else None) if rows else None
    if data is None or data.shape[1] != len(names):
        data = _parse_slowly(source, rows, linenos, names, sep, expect)
    bad = ~np.isfinite(data[:, list(used)])
    if bad.any():
        i, k = (int(v) for v in np.argwhere(bad)[0])
        j = list(used)[k]
        field = _fields(rows[i], sep)[j].strip()
        raise LogError(source, f"{field!r} is not a finite number", int(linenos[i]),
                       _label(j, names[j]))
    if len(rows) < MIN_SAMPLES:
        raise LogError(source, f"has {len(rows)} samples; a log needs {MIN_SAMPLES} or more")
    return data


def _parse_slowly(source: str, rows: list[str], linenos: NDArray[np.int64], names: list[str],
                  sep: str | None, expect: str) -> NDArray[np.float64]:
    out = np.empty((len(rows), len(names)))
    for i, row in enumerate(rows):
        fields = _fields(row, sep)
        if sep is None and fields == ["overrun"]:
            raise LogError(source, "halsampler wrote 'overrun': samples were lost here (its "
                           "FIFO was full); record again with a deeper FIFO (loadrt sampler "
                           "depth=...)", int(linenos[i]))
        if len(fields) != len(names):
            raise LogError(source, f"{len(fields)} fields; {expect}", int(linenos[i]))
        for j, field in enumerate(fields):
            try:
                out[i, j] = float(field)
            except ValueError:
                what = "is empty" if not field.strip() else f"{field.strip()!r} is not a number"
                raise LogError(source, what, int(linenos[i]), _label(j, names[j])) from None
    return out


def _scale(source: str, length_unit: str) -> float:
    if length_unit not in LENGTH_UNITS:
        raise LogError(source, f"length_unit {length_unit!r} is not one of "
                       f"{', '.join(LENGTH_UNITS)}")
    return LENGTH_UNITS[length_unit]


def _layout(source: str, entries: list[tuple[int, str, str, str]], line: int | None) -> Layout:
    """Axis -> kind -> column of ``(column, name, axis, kind)`` entries; each axis has cmd, fb."""
    layout: Layout = {}
    label = {j: _label(j, name) for j, name, _, _ in entries}
    for j, _, axis, kind in entries:
        cols = layout.setdefault(axis, {})
        if kind in cols:
            raise LogError(source, f"a second {kind} column of axis {axis!r} (the first is "
                           f"column {label[cols[kind]]})", line, label[j])
        cols[kind] = j
    for axis, cols in layout.items():
        missing = [k for k in ("cmd", "fb") if k not in cols]
        if missing:
            have = " and ".join(k for k in _KINDS if k in cols)
            raise LogError(source, f"axis {axis!r} has {have} but no {' or '.join(missing)} "
                           "column: an axis needs both cmd and fb", line,
                           label[min(cols.values())])
    return layout


def _check_time(source: str, time: NDArray[np.float64], linenos: NDArray[np.int64],
                column: str) -> None:
    bad = np.flatnonzero(np.diff(time) <= 0)
    if bad.size:
        i = int(bad[0])
        raise LogError(source, f"time {float(time[i + 1])!r} s does not increase from "
                       f"{float(time[i])!r} s on line {int(linenos[i])}", int(linenos[i + 1]),
                       column)


def _build(source: str, time: NDArray[np.float64], data: NDArray[np.float64], layout: Layout,
           scale: float) -> ServoLog:
    """The log of the parsed ``data``; refused if no axis moved (:attr:`ServoLog.still`)."""
    axes = [AxisLog(name, **{k: data[:, j] * (1.0 if k == "effort" else scale)
                             for k, j in cols.items()}) for name, cols in layout.items()]
    spans = {a.name: float(np.ptp(a.cmd)) for a in axes}
    if all(span < STILL_BELOW for span in spans.values()):
        each = ", ".join(f"{n} {s * 1e6:.3f} um" for n, s in spans.items())
        raise LogError(source, f"no axis moved: the commands span {each} (each needs "
                       f"{STILL_BELOW * 1e6:g} um)")
    return ServoLog(time, tuple(axes), source)


def read_csv(path: PathLike, length_unit: str = "m") -> ServoLog:
    """Read a CSV servo log (the module's docstring gives the format).

    Args:
        path: The file.
        length_unit: Unit of cmd, fb and vel_cmd (``"m"``, ``"mm"``, ``"inch"``; vel_cmd per
            second); time is in seconds.

    Returns:
        The log, in s and m.

    Raises:
        LogError: no time column; an unknown or repeated column; an axis without cmd or fb; a
            row of another field count than the header; a field not a finite number; time not
            strictly increasing; fewer than :data:`MIN_SAMPLES` rows; a still axis.
    """
    source, lines = _read_lines(path)
    scale = _scale(source, length_unit)
    h = next((i for i, s in enumerate(lines) if s.strip()), None)
    if h is None:
        raise LogError(source, f"is empty: a CSV log needs a header naming {_CSV_NAMES}")
    names = [f.strip() for f in _fields(lines[h], ",")]
    time_col, layout = _csv_layout(source, names, lines[h], h + 1)
    rows, linenos = _rows(lines, h + 1)
    data = _parse(source, rows, linenos, names, ",", f"the header has {len(names)}",
                  range(len(names)))
    time = data[:, time_col].copy()
    _check_time(source, time, linenos, _label(time_col, names[time_col]))
    return _build(source, time, data, layout, scale)


def _csv_layout(source: str, names: list[str], header: str, line: int) -> tuple[int, Layout]:
    """The time column and the axes of a CSV header."""
    keys = [name.lower() for name in names]
    if "time" not in keys:
        hint = "; the fields are split at commas" if ";" in header else ""
        raise LogError(source, f"the header has no time column (s){hint}", line)
    time_col, entries = keys.index("time"), []
    for j, (key, name) in enumerate(zip(keys, names, strict=True)):
        match = _PLAIN.fullmatch(key)
        if key == "time" and j != time_col:
            raise LogError(source, "a second time column (the first is column "
                           f"{_label(time_col, names[time_col])})", line, _label(j, name))
        if match is None and key != "time":
            raise LogError(source, f"unknown column: a CSV log's columns are {_CSV_NAMES}",
                           line, _label(j, name))
        if match is not None:
            entries.append((j, name, match[1], match[2]))
    return time_col, _layout(source, entries, line)


def _joint_map(source: str, joints: Joints) -> dict[int, str]:
    """Joint number -> axis name of ``joints`` (a mapping or ``"0=x,1=y"``)."""
    if joints is None:
        return dict(enumerate(DEFAULT_JOINTS))
    items: list[tuple[Any, Any]] = list(joints.items()) if not isinstance(joints, str) else [
        (k, v) for k, _, v in (p.partition("=") for p in joints.split(","))]
    out: dict[int, str] = {}
    for key, value in items:
        name = str(value).strip().lower()
        joint = int(key) if str(key).strip().isdigit() else None
        if joint is None or not _AXIS.fullmatch(name):
            raise LogError(source, f"joints {joints!r}: {key}={value} is not <joint number>="
                           "<axis name> (like 0=x, 2=y1)")
        if joint in out or name in out.values():
            raise LogError(source, f"joints {joints!r}: joint {joint} or axis {name!r} twice")
        out[joint] = name
    return out


def _pin_axis(source: str, j: int, pin: str, joint_axes: dict[int, str]) -> tuple[str, str]:
    """(axis, kind) of a column's pin name."""
    key = pin.strip().lower()
    plain, hal = _PLAIN.fullmatch(key), _PIN.fullmatch(key)
    if plain:
        return plain[1], plain[2]
    if hal:
        part, instance, leaf = hal.groups()
        kind = _JOINT_PINS.get(leaf) if part == "joint" else "effort" if leaf == "output" else None
        if kind and instance.isdigit():
            if int(instance) not in joint_axes:
                known = ",".join(f"{k}={v}" for k, v in joint_axes.items())
                raise LogError(source, f"joint {int(instance)} has no axis in joints "
                               f"({known}): add {int(instance)}=<axis>", column=_label(j, pin))
            return joint_axes[int(instance)], kind
        if kind and part == "pid" and _AXIS.fullmatch(instance):
            return instance, kind
    raise LogError(source, f"not a pin this reader knows; it knows {_PIN_NAMES}",
                   column=_label(j, pin))


def _pin_layout(source: str, columns: str | Sequence[str],
                joint_axes: dict[int, str]) -> tuple[list[str], Layout]:
    """The pin names of ``columns`` and the axes they give."""
    pins = [str(p).strip() for p in (columns.split(",") if isinstance(columns, str) else columns)]
    if "" in pins:
        raise LogError(source, f"columns {columns!r}: column {pins.index('') + 1} has no name "
                       "(name a column to skip '-')")
    entries = [(j, pin, *_pin_axis(source, j, pin, joint_axes))
               for j, pin in enumerate(pins) if pin != "-"]
    if not entries:
        raise LogError(source, f"columns {pins} name no axis column")
    return pins, _layout(source, entries, None)


def _tagged(source: str, rows: list[str], linenos: NDArray[np.int64], n: int) -> bool:
    """Whether the rows start with halsampler -t's sample number (judged by the first row)."""
    count = len(rows[0].split()) if rows else n
    if count not in (n, n + 1):
        raise LogError(source, f"{count} fields; columns names {n} (or {n + 1} with "
                       "halsampler -t's sample number first)", int(linenos[0]))
    return count == n + 1


def _tag_time(source: str, tags: NDArray[np.float64], linenos: NDArray[np.int64],
              period: float) -> NDArray[np.float64]:
    """Sample number x period; refused where the number does not count up by 1."""
    bad, column = np.flatnonzero(np.diff(tags) != 1), _label(0, _TAG)
    if tags[0] != np.floor(tags[0]):
        raise LogError(source, f"{float(tags[0])!r} is not a sample number (columns names one "
                       "field fewer)", int(linenos[0]), column)
    if bad.size:
        i = int(bad[0])
        a, b = float(tags[i]), float(tags[i + 1])
        lost = b - a - 1
        what = (f"the sample number jumps from {a:.0f} to {b:.0f}: {lost:.0f} samples were lost "
                "(a halsampler overrun)" if lost >= 1 and b == np.floor(b) else
                f"{b!r} does not follow sample number {a:.0f} (columns names one field fewer)")
        raise LogError(source, what, int(linenos[i + 1]), column)
    return tags * period


def read_halsampler(path: PathLike, columns: str | Sequence[str], period: float,
                    joints: Joints = None, length_unit: str = "m") -> ServoLog:
    """Read what LinuxCNC's ``halsampler`` printed (with or without ``-t``).

    ``columns`` names each column by its HAL pin: ``joint.N.motor-pos-cmd`` or
    ``joint.N.pos-cmd`` (cmd), ``joint.N.motor-pos-fb`` or ``joint.N.pos-fb`` (fb),
    ``joint.N.vel-cmd``, ``pid.N.output`` or ``joint.N.effort`` (effort; ``pid.x.output`` is
    axis x's, as pncconf names PIDs). Any column may be named plainly (``x_cmd``, ``x_fb``,
    ``x_effort``, ``x_vel_cmd``: an effort pin of another component is ``x_effort``); ``-``
    skips one. ``overrun`` lines before the first sample (losses before it) are skipped.

    Args:
        path: The file.
        columns: The pins, in file order: a comma-separated string or a sequence.
        period: The sampler's thread period, s: time is the sample number (``-t``'s, else the
            row's index from 0) times ``period``.
        joints: Joint number -> axis name: ``{0: "x", 1: "y"}`` or ``"0=x,1=y,2=y1"``; None
            maps joints 0, 1, 2, ... to :data:`DEFAULT_JOINTS` (x, y, z, a, b, c, u, v, w).
        length_unit: The machine's length unit (``"m"``, ``"mm"``, ``"inch"``).

    Returns:
        The log, in s and m.

    Raises:
        LogError: what :func:`read_csv` refuses; a field count other than ``columns``'s (one
            more with ``-t``); an unknown pin; a joint not in ``joints``; lost samples.
    """
    source, lines = _read_lines(path)
    scale = _scale(source, length_unit)
    if not 0 < float(period) < float("inf"):
        raise LogError(source, f"period {period!r} is not a time step > 0 s")
    pins, layout = _pin_layout(source, columns, _joint_map(source, joints))
    rows, linenos = _rows(lines, 0)
    while rows and rows[0].strip() == "overrun":
        rows, linenos = rows[1:], linenos[1:]
    tag = int(_tagged(source, rows, linenos, len(pins)))
    names = [_TAG] * tag + pins
    expect = f"columns names {len(pins)}" + (f" and -t's sample number: {len(names)}" * tag)
    used = [0] * tag + [j + tag for cols in layout.values() for j in cols.values()]
    data = _parse(source, rows, linenos, names, None, expect, used)
    tags = data[:, 0] if tag else np.arange(len(rows), dtype=np.float64)
    time = _tag_time(source, tags, linenos, period)
    return _build(source, time, data[:, tag:], layout, scale)


def _has_time_header(path: PathLike) -> bool:
    """Whether the file's first non-blank line has a ``time`` field (a CSV header)."""
    with open(path, "rb") as f:
        for raw in f:
            text = raw.decode("utf-8", "replace").removeprefix("\ufeff")
            if text.strip():
                return "time" in (field.strip().lower() for field in _fields(text, ","))
    return False


def read_log(path: PathLike, *, columns: str | Sequence[str] | None = None,
             period: float | None = None, joints: Joints = None,
             length_unit: str = "m") -> ServoLog:
    """Read a servo log: a CSV if its first non-blank line has a ``time`` field, else halsampler.

    ``columns`` and ``period`` (required) and ``joints`` are :func:`read_halsampler`'s and
    are refused for a CSV; ``length_unit`` is the unit of lengths in the file.

    Raises:
        LogError: halsampler options given for a CSV, or missing for a halsampler file; and
            whatever :func:`read_csv` or :func:`read_halsampler` refuses.
    """
    source = os.fspath(path)
    options = {"columns": columns, "period": period, "joints": joints}
    if _has_time_header(path):
        given = [k for k, v in options.items() if v is not None]
        if given:
            raise LogError(source, f"is a CSV (its header has a time column): {', '.join(given)}"
                           " are for halsampler files; leave them out")
        return read_csv(path, length_unit)
    missing = [k for k in ("columns", "period") if options[k] is None]
    if missing or columns is None or period is None:
        raise LogError(source, "has no CSV header with a time column, so it is read as "
                       f"halsampler output, which needs {' and '.join(missing)}: columns= the "
                       "HAL pin of each column, period= the sampler's thread period in s")
    return read_halsampler(path, columns, period, joints, length_unit)


def _axis_columns(axis: AxisLog, scale: float) -> list[tuple[str, NDArray[np.float64]]]:
    """(kind, values in the file's unit) of an axis's logged signals."""
    out = [("cmd", axis.cmd / scale), ("fb", axis.fb / scale)]
    if axis.effort is not None:
        out.append(("effort", axis.effort))
    if axis.vel_cmd is not None:
        out.append(("vel_cmd", axis.vel_cmd / scale))
    return out


def _lines(columns: list[NDArray[np.float64]], sep: str) -> list[str]:
    """One line per sample, each float with the digits that read back to it (``repr``)."""
    return [sep.join(map(repr, row)) for row in np.column_stack(columns).tolist()]


def write_csv(log: ServoLog, path: PathLike, length_unit: str = "m") -> None:
    """Write ``log`` as a CSV that :func:`read_csv` reads back (lengths in ``length_unit``).

    The file is replaced at once (written beside it, then renamed): never left half written.
    """
    scale = _scale(os.fspath(path), length_unit)
    names, columns = ["time"], [log.time]
    for axis in log.axes:
        for kind, values in _axis_columns(axis, scale):
            names.append(f"{axis.name}_{kind}")
            columns.append(values)
    write_text(Path(path), "\n".join([",".join(names), *_lines(columns, ",")]) + "\n")


def _pin(axis: str, kind: str, joint: int | None) -> str:
    if joint is None:
        return f"{axis}_{kind}"
    return {"cmd": f"joint.{joint}.motor-pos-cmd", "fb": f"joint.{joint}.motor-pos-fb",
            "effort": f"pid.{joint}.output", "vel_cmd": f"joint.{joint}.vel-cmd"}[kind]


def write_halsampler(log: ServoLog, path: PathLike, joints: Joints = None,
                     length_unit: str = "m", tag: bool = False) -> str:
    """Write ``log`` as halsampler output; return the ``columns`` that read it back.

    Read it back with ``read_halsampler(path, columns, period, joints, length_unit)``, the
    log's time step as ``period``: it rebuilds time from the sample number, ``round(time /
    period)`` with ``tag`` (``-t``), else the row index (the time origin is lost). Axes in
    ``joints`` get the pins ``joint.N.motor-pos-cmd``, ``joint.N.motor-pos-fb``,
    ``pid.N.output`` and ``joint.N.vel-cmd``; other axes plain names (``y1_cmd``, ...).
    Floats keep every digit (halsampler prints six decimals). Written atomically.

    Raises:
        LogError: when the log's time is not a uniform grid (with ``tag``: of multiples of
            its period), which halsampler rows cannot carry.
    """
    target = os.fspath(path)
    scale = _scale(target, length_unit)
    joint_of = {name: j for j, name in _joint_map(target, joints).items()}
    pins, columns = [], []
    for axis in log.axes:
        for kind, values in _axis_columns(axis, scale):
            pins.append(_pin(axis.name, kind, joint_of.get(axis.name)))
            columns.append(values)
    period = log.period
    since = log.time - (0.0 if tag else log.time[0])
    steps = np.rint(since / period)
    off = np.abs(since - steps * period)
    if np.any(np.diff(steps) != 1) or float(off.max()) > 1e-6 * period:
        grid = "multiples of" if tag else "steps of"
        raise LogError(target, f"the log's time is not on a grid of {grid} its period "
                       f"{period!r} s: halsampler rows carry no time")
    lines = _lines(columns, " ")
    if tag:
        lines = [f"{int(k)} {line}" for k, line in zip(steps.tolist(), lines, strict=True)]
    write_text(Path(path), "\n".join(lines) + "\n")
    return ",".join(pins)


def _fitted_step(moves: NDArray[np.float64], step: float) -> float:
    """``step`` refined by least squares on the moves up to 8, 64, 512, ... smallest moves."""
    limit = 8.0 * float(moves.min())
    while True:
        some = moves[moves <= limit]
        whole = np.rint(some / step)
        step = float(np.dot(some, whole) / np.dot(whole, whole))
        if limit >= moves.max():
            return step
        limit *= 8


def encoder_step(fb: ArrayLike) -> float | None:
    """The quantisation step of a measured position, or None if it does not look quantised.

    Method: the nonzero moves ``|diff(fb)|`` (above float64 noise of ``fb``'s magnitude) are
    tried as integer multiples of the smallest move divided by 1, 2, ... 16 (the first divisor
    that fits gives the greatest common step). Each trial step is refined by least squares on
    the moves up to 8 smallest moves, then 64, 512, ... (so a smallest move that is rounded,
    as halsampler's six decimals round it, still fits), and fits if every move is within 0.02
    of a step of a multiple. None with fewer than 20 moves or when no divisor fits. The step
    is given to 12 significant digits: the fit's last bits are float noise, and a simulated
    encoder whose axis settles near a step's edge reads on them.

    ``fb`` may be in any unit: the step is in the same.

    Example:
        >>> round(encoder_step(np.round(np.sin(np.linspace(0, 6, 500)) * 1e4) * 1e-7), 12)
        1e-07
    """
    x = np.asarray(fb, dtype=np.float64)
    if x.ndim != 1 or not np.all(np.isfinite(x)):
        raise ValueError("fb must be a one-dimensional array of finite numbers")
    moves = np.abs(np.diff(x))
    floor = 64 * np.finfo(np.float64).eps * float(np.max(np.abs(x), initial=0.0))
    moves = moves[moves > floor]
    if moves.size < _STEP_MIN_MOVES:
        return None
    smallest = float(moves.min())
    for divisor in range(1, _STEP_DIVISORS + 1):
        step = smallest / divisor
        if step <= 1024 * floor or float(moves.max()) / step > _STEP_MAX_COUNT:
            return None
        step = _fitted_step(moves, step)
        counts = moves / step
        if np.all(np.abs(counts - np.rint(counts)) <= _STEP_TOLERANCE):
            return float(f"{step:.12g}")
    return None
