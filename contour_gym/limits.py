"""Sizes checked against the machine before they are allocated: the one check and its words.

:func:`check_size` refuses, before anything is allocated or started, a size whose memory would
not fit in what this machine has available (or in a stated cap), saying how much it would
need, how much there is, and what to lower.
"""

from __future__ import annotations

import os

# a size may take at most this share of the memory available when it is checked
AVAILABLE_SHARE = 0.8


def available_bytes() -> int:
    """Memory this machine has available now, bytes (``MemAvailable``; else free pages)."""
    try:
        with open("/proc/meminfo", encoding="ascii") as handle:
            for line in handle:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return int(os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
    except (ValueError, OSError, AttributeError):  # pragma: no cover - no way to ask
        return 1 << 62


def gigabytes(n: float) -> str:
    """``n`` bytes in words: ``"2 TB"``, ``"3.4 GB"``, ``"120 MB"``, ``"7.8 kB"``."""
    if n >= 1e12:
        return f"{n / 1e12:.3g} TB"
    if n >= 1e9:
        return f"{n / 1e9:.3g} GB"
    return f"{n / 1e6:.3g} MB" if n >= 1e6 else f"{n / 1e3:.3g} kB"


def check_size(need: float, what: str, lower: str, cap: float | None = None) -> None:
    """Refuse ``what`` if its ``need`` bytes exceed the memory available (or ``cap``).

    Args:
        need: Bytes the allocation or run would hold.
        what: What it is, with its size ("a vector env of 10000000 members").
        lower: What the user may lower ("num_envs").
        cap: A fixed limit, bytes, besides the machine's.

    Raises:
        ValueError: naming ``what``, the bytes it needs, the limit and ``lower``.
    """
    have = AVAILABLE_SHARE * available_bytes()
    limit = have if cap is None else min(have, cap)
    if need > limit:
        where = (f"{gigabytes(have)} of this machine's available memory" if limit == have
                 else f"the limit of {gigabytes(limit)}")
        raise ValueError(f"{what} would need {gigabytes(need)}, more than {where}: lower {lower}")
