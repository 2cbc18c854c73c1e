"""G-code lexing: comments, words, and a block's words sorted into G/M codes and values.

The first stage of the reader (:mod:`contour_gym.paths._gcode`): a text line becomes a
:class:`_Block` (G codes by modal group, value words, M codes by group, the T word), or a
:class:`GcodeError` naming the line and the word it cannot accept. The code tables here say
which G and M codes the reader honours, ignores or rejects, and why.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from decimal import Decimal
from typing import Any

_WORD = re.compile(r"\s*([A-Za-z])\s*([+-]?(?:\d+\.?\d*|\.\d+))", re.ASCII)  # ASCII digits only
_EXPONENT = re.compile(r"[eE][+-]?\d+", re.ASCII)  # right after a number: 1e12
_O_WORD = re.compile(r"O\s*(\d+|<[^>]*>)\s*(.*)$", re.IGNORECASE | re.ASCII)
_MACRO = re.compile(r"[A-Za-z]?\s*#\s*(?:<[^>]*>|\d+)?", re.ASCII)
_EXPR = re.compile(r"[A-Za-z]*\s*\[[^\]]*\]?")
WORK_SYSTEMS = ("G54", "G55", "G56", "G57", "G58", "G59", "G59.1", "G59.2", "G59.3")
"""The work coordinate systems a program may select (keys of ``from_gcode``'s ``work_offsets``)."""
_G_GROUP: dict[float, str] = {
    0.0: "motion", 1.0: "motion", 2.0: "motion", 3.0: "motion",
    4.0: "non-modal", 28.0: "non-modal", 53.0: "non-modal",
    17.0: "plane", 18.0: "plane", 19.0: "plane", 20.0: "units", 21.0: "units",
    90.0: "distance", 91.0: "distance", 90.1: "arc distance", 91.1: "arc distance",
    43.0: "tool length", 49.0: "tool length", 61.0: "path control", 61.1: "path control",
    64.0: "path control", 40.0: "cutter compensation", 80.0: "canned cycle", 94.0: "feed mode",
    **{float(name[1:]): "coordinate system" for name in WORK_SYSTEMS},
}
_G_NOOP = {40.0, 80.0, 94.0}
_G_REJECT: dict[float, str] = {
    93.0: "inverse-time feed", 95.0: "feed per revolution",
    **dict.fromkeys((41.0, 42.0, 41.1, 42.1), "cutter radius compensation"),
    **dict.fromkeys((43.1, 43.2), "dynamic tool length offset; use G43 H and tool_lengths"),
    **dict.fromkeys((73.0, 74.0, 76.0, *map(float, range(81, 90))), "canned cycle"),
    **dict.fromkeys((30.0, 28.1, 30.1), "reference points are machine data"),
    **dict.fromkeys((10.0, 52.0, 92.0, 92.1, 92.2, 92.3),
                    "offsets set by the program; pass work_offsets and tool_lengths"),
    **dict.fromkeys((65.0, 66.0, 66.1, 67.0), "macro call"),
}
_M_GROUP = {0: "stop", 1: "stop", 2: "stop", 30: "stop", 3: "spindle", 4: "spindle",
            5: "spindle", 19: "spindle", 6: "tool change", 7: "coolant", 8: "coolant",
            9: "coolant"}
_M_REJECT = {97: "local subroutine call", 98: "subroutine call", 99: "subroutine return"}
_VALUE_WORDS = set("XYZIJKRFPQH")


class GcodeError(ValueError):
    """A G-code line that cannot be run: a ValueError naming the line number and the word.

    Attributes:
        line: 1-based text line of the program.
        word: The offending word (``"G93"``, ``"M98"``, ``"X[1+2]"``, ...) or text.
    """

    def __init__(self, line: int, word: str, message: str) -> None:
        super().__init__(f"G-code line {line}: {message}")
        self.line = line
        self.word = word
        self.message = message

    def __reduce__(self) -> tuple[Any, ...]:
        return (GcodeError, (self.line, self.word, self.message))


@dataclass
class _Block:
    lineno: int
    g: dict[str, float] = field(default_factory=dict)
    values: dict[str, float] = field(default_factory=dict)
    m: dict[str, int] = field(default_factory=dict)
    tool: int | None = None

    def error(self, word: str, message: str) -> GcodeError:
        return GcodeError(self.lineno, word, message)


def _strip(raw: str, lineno: int) -> str:
    """The line without comments and block delete (``;`` inside parentheses is comment text)."""
    out = []
    depth = 0
    for ch in raw:
        if ch == ";" and not depth:
            break
        if ch == "(":
            if depth:
                raise GcodeError(lineno, raw.strip(), f"nested comment: {raw.strip()!r}")
            depth = 1
        elif ch == ")":
            if not depth:
                raise GcodeError(lineno, raw.strip(), f"unmatched ')': {raw.strip()!r}")
            depth = 0
        elif not depth:
            out.append(ch)
    if depth:
        raise GcodeError(lineno, raw.strip(), f"unclosed comment: {raw.strip()!r}")
    line = "".join(out).strip()
    if line.startswith("/"):
        line = line[1:].strip()
    return line


def _reject_macros(line: str, lineno: int) -> None:
    found = [(line.find(char), pattern, what) for char, pattern, what in (
        ("#", _MACRO, "macro variables and parameters (#)"),
        ("[", _EXPR, "expressions in brackets"))]
    found = [f for f in found if f[0] >= 0]
    if found:
        at, pattern, what = min(found, key=lambda f: f[0])
        m = pattern.search(line, max(at - 1, 0))
        word = m.group(0).strip() if m else line[at:]
        raise GcodeError(lineno, word, f"{word!r}: {what} are not supported")


def _tokens(line: str, lineno: int) -> list[tuple[str, float]]:
    words = []
    pos = 0
    while pos < len(line):
        m = _WORD.match(line, pos)
        if m is None:
            rest = line[pos:].strip()
            if not rest:
                break
            raise GcodeError(lineno, rest, f"cannot read {rest!r}")
        exponent = _EXPONENT.match(line, m.end())
        if exponent is not None:  # F1e12: the controller would read F1 and an E word
            word = m.group(0).strip() + exponent.group(0)
            raise GcodeError(lineno, word, f"{word}: G-code numbers have no exponent; write "
                                           f"{_plain(m.group(2) + exponent.group(0))} out")
        words.append((m.group(1).upper(), float(m.group(2))))
        pos = m.end()
    return words


def _plain(number: str) -> str:
    # a number with an exponent in plain digits: "1e12" -> "1000000000000"
    return format(Decimal(number).normalize(), "f")


def _add_g(blk: _Block, num: float) -> None:
    word = f"G{num:g}"
    if num in _G_REJECT:
        raise blk.error(word, f"unsupported code {word} ({_G_REJECT[num]})")
    group = _G_GROUP.get(num)
    if group is None:
        raise blk.error(word, f"unsupported code {word}")
    if num in _G_NOOP:
        return
    if group in blk.g:
        raise blk.error(word, f"two {group} codes on one line (G{blk.g[group]:g}, {word})")
    blk.g[group] = num


def _add_m(blk: _Block, num: float) -> None:
    word = f"M{num:g}"
    if num in _M_REJECT:
        raise blk.error(word, f"unsupported code {word} ({_M_REJECT[int(num)]})")
    group = _M_GROUP.get(int(num)) if num == int(num) else None
    if group is None:
        raise blk.error(word, f"unsupported code {word}")
    if group in blk.m and group != "coolant":
        raise blk.error(word, f"two {group} codes on one line (M{blk.m[group]}, {word})")
    blk.m[group] = int(num)


def _classify(words: list[tuple[str, float]], lineno: int) -> _Block:
    """Sort a block's words into G codes by group, value words, M codes and T; reject the rest."""
    blk = _Block(lineno)
    for letter, num in words:
        if letter == "G":
            _add_g(blk, num)
        elif letter == "M":
            _add_m(blk, num)
        elif letter in _VALUE_WORDS:
            if letter in blk.values:
                raise blk.error(letter, f"word {letter} given twice")
            blk.values[letter] = num
        elif letter == "T":
            blk.tool = _whole(blk, "T", num)
        elif letter not in "NS":
            raise blk.error(f"{letter}{num:g}", f"unsupported word {letter}{num:g}")
    _check_words(blk)
    return blk


def _whole(blk: _Block, letter: str, num: float) -> int:
    if num != int(num) or num < 0:
        raise blk.error(f"{letter}{num:g}", f"{letter}{num:g} must be a whole number >= 0")
    return int(num)


def _check_words(blk: _Block) -> None:
    v, g = blk.values, blk.g
    dwell, g64 = g.get("non-modal") == 4.0, g.get("path control") == 64.0
    if "P" in v and dwell == g64:
        what = "is ambiguous with both G4 and G64 on one line" if dwell else \
            "needs G4 (dwell) or G64 (path tolerance)"
        raise blk.error(f"P{v['P']:g}", f"P{v['P']:g} {what}")
    if "Q" in v and not g64:
        raise blk.error(f"Q{v['Q']:g}", f"Q{v['Q']:g} needs G64")
    if "H" in v and g.get("tool length") != 43.0:
        raise blk.error(f"H{v['H']:g}", f"H{v['H']:g} needs G43")
    if "F" in v and v["F"] <= 0.0:
        raise blk.error(f"F{v['F']:g}", f"feedrate must be > 0, got F{v['F']:g}")
