"""How close to the papers: every published baseline row against ours, ideal and on the rig.

For each row of ``contour_gym.papers.ROWS`` (000's circle, 004's circle and corner, 003's 2PID
tables 2 and 3, 001's PID-CCC row, 002's tracking error): the paper's figure, ours with
``ideal=True``, ours on the rig, the ratio of the judged one (the rig for experiments, ideal for
simulations) and HOLDS / FALLS SHORT against the row's band (issue 14, item 1); rows without a
band are reported. Deterministic (seed 0). Prints Markdown (``--notes`` adds each row's note).
"""

from __future__ import annotations

import argparse
import time

from contour_gym.papers import ROWS, as_markdown, fidelity_table


def main() -> None:
    """Print the fidelity table."""
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--notes", action="store_true", help="print each row's note")
    parser.add_argument("--paper", default=None, help="only this paper's rows (e.g. 003)")
    args = parser.parse_args()
    rows = tuple(r for r in ROWS if args.paper is None or r.paper == args.paper)
    t0 = time.perf_counter()
    table = fidelity_table(rows)
    print(as_markdown(table))
    print(f"\n{len(rows)} rows in {time.perf_counter() - t0:.1f} s; "
          f"{sum(t['verdict'] == 'HOLDS' for t in table)} hold, "
          f"{sum(t['verdict'] == 'FALLS SHORT' for t in table)} fall short, "
          f"{sum(t['verdict'] == 'reported' for t in table)} reported")
    if args.notes:
        for note in dict.fromkeys(r.note for r in rows if r.note):
            print(f"\n- {note}")


if __name__ == "__main__":
    main()
