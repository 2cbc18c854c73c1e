"""The papers' baseline rows as data: what each paper reports, and the scenario that measures ours.

Each :class:`BaselineRow` names a figure a paper publishes for its *baseline* (no CCC, the
untuned controller, the constant feedrate), the scenario that runs it here (preset, path, laps,
options), the metric compared, and the band it must fall in: ``("rel", r)`` for within
``r`` (relative) of the paper's figure, ``("factor", f)`` for within a factor ``f`` either way,
or None for a row reported without a band. Rows from an experiment are judged on the rig, rows
from a simulation with ``ideal=True``. ``benchmarks/paper_fidelity.py`` prints the table; the
papers' improvement ratios (reference policies, tuning) are measured on these same scenarios.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from contour_gym.api import make_scenario, run_scenario
from contour_gym.envs.registration import GANTRY_LEAF

Metrics = Mapping[str, Any]


@dataclass(frozen=True)
class BaselineRow:
    """One published baseline figure and how ours is measured.

    Attributes:
        key: Short identifier.
        paper: Paper prefix ("000".."004").
        what: The row in words (for the table).
        figure: The paper's value, in ``unit``.
        unit: ``"um"``, ``"mm"``, ``"s"`` or ``"%"``.
        plant: The scenario's machine (name or override dict).
        path: Library path name.
        metric: Our value, in ``unit``, from the run's metrics (batch member 0's arrays).
        options: Further :func:`~contour_gym.api.make_scenario` arguments.
        ccc: Whether the run uses the preset's CCC gains.
        experiment: The paper's figure is measured on hardware: judged on the rig.
        band: ``("rel", r)``, ``("factor", f)`` or None (reported only).
        note: Why a row falls short, or what the comparison assumes.
    """

    key: str
    paper: str
    what: str
    figure: float
    unit: str
    plant: str | Mapping[str, Any]
    path: str
    metric: Callable[[Metrics], float]
    options: Mapping[str, Any] = field(default_factory=dict)
    ccc: bool = False
    experiment: bool = False
    band: tuple[str, float] | None = None
    note: str = ""

    def measure(self, ideal: bool, seed: int = 0) -> float:
        """Our value of the row (rig unless ``ideal``)."""
        scenario = make_scenario(self.plant, self.path, ideal=ideal, **self.options)
        gains = scenario.preset.ccc_gains if self.ccc else None
        return self.metric(run_scenario(scenario, gains, seed).metrics())

    def verdict(self, ours: float) -> str:
        """``HOLDS``, ``FALLS SHORT`` against the band, or ``reported`` without one."""
        if self.band is None:
            return "reported"
        kind, size = self.band
        ratio = ours / self.figure
        ok = abs(ratio - 1.0) <= size if kind == "rel" else 1.0 / size <= ratio <= size
        return "HOLDS" if ok and math.isfinite(ours) else "FALLS SHORT"

    def band_text(self) -> str:
        """The band in words."""
        if self.band is None:
            return "-"
        kind, size = self.band
        return f"+-{size:.0%}" if kind == "rel" else f"x{size:g}"


def _scalar(key: str, scale: float) -> Callable[[Metrics], float]:
    return lambda m: float(m[key][0]) * scale


def _column(key: str, j: int, scale: float) -> Callable[[Metrics], float]:
    return lambda m: float(m[key][0, j]) * scale


UM, MM = 1e6, 1e3
_003 = {"sample_period": 0.1}  # 003 eqs. 39-40 sample at 10 Hz over the 10 s window
_LEAF: dict[str, Any] = {
    "plant": GANTRY_LEAF, "path": "three_leaf", "options": {**_003, "laps": 20}
}
_CIRCLE50: dict[str, Any] = {
    "plant": "xyy_gantry", "path": "circle_r50", "options": {**_003, "laps": 10}
}
_003_NOTE = (
    "003's hand-tuned 2PID (Kp per encoder count, Kp_y2 0.0007) on its identified model: the "
    "axis errors match table 2 within 30 % but on the circle the x and y2 loops lag nearly in "
    "phase, so their errors are mostly tangential; the paper's contour errors, as large as its "
    "axis errors, need a coupling the published model does not carry (unmodelled: the dual-y "
    "beam, the real ripple)."
)


def _gantry_rows() -> list[BaselineRow]:
    rows = []
    for case, spec, table, figures in (
        ("circle", _CIRCLE50, "table 2", (0.777, 0.882, 0.643, 1.205, 0.729, 0.769, 1.277)),
        ("three-leaf", _LEAF, "table 3", (0.671, 0.743, 0.621, 0.830, 0.654, 0.557, 1.006)),
    ):
        e1, e2, peps, pe, ex, ey1, ey2 = figures
        items = (
            ("eps1", "max |eps1|", e1, _column("max_contour_error_per_contour", 0, MM)),
            ("eps2", "max |eps2|", e2, _column("max_contour_error_per_contour", 1, MM)),
            ("peps", "P_eps", peps, _scalar("p_eps", MM)),
            ("pe", "P_e", pe, _scalar("p_e", MM)),
            ("ex", "max |e_x|", ex, _column("max_tracking_error", 0, MM)),
            ("ey1", "max |e_y1|", ey1, _column("max_tracking_error", 1, MM)),
            ("ey2", "max |e_y2|", ey2, _column("max_tracking_error", 2, MM)),
        )
        for key, what, figure, metric in items:
            rows.append(BaselineRow(
                f"003-{case}-{key}", "003", f"{case} 2PID, {what} ({table})", figure, "mm",
                spec["plant"], spec["path"], metric, spec["options"], experiment=True,
                band=("factor", 2.0), note=_003_NOTE,
            ))
    return rows


ROWS: tuple[BaselineRow, ...] = (
    BaselineRow(
        "000-sim", "000", "circle r 10 mm, no CCC, max error (simulation)", 49.0, "um",
        "xy_dc_servo", "circle_r10", _scalar("max_contour_error", UM), band=("rel", 0.15),
    ),
    BaselineRow(
        "000-exp", "000", "circle r 10 mm, no CCC, max error (experiment)", 115.0, "um",
        "xy_dc_servo", "circle_r10", _scalar("max_contour_error", UM), experiment=True,
        note="the rig adds a 1 um encoder and a one-tick delay; the friction and backlash of "
        "000's table are unpublished, so the experiment's extra 66 um is not modelled",
    ),
    BaselineRow(
        "001-pidccc-max", "001", "screw curve, SMC+DOB axes, PID-CCC, max contour error",
        122.2, "um", "xyz_pmlsm", "helix", _scalar("max_contour_error", UM), ccc=True,
        note="001's machine and controller tables were lost in extraction (chosen values); "
        "its unit is not printed (read as um)",
    ),
    BaselineRow(
        "001-pidccc-mean", "001", "screw curve, SMC+DOB axes, PID-CCC, mean contour error",
        17.7, "um", "xyz_pmlsm", "helix", _scalar("mean_contour_error", UM), ccc=True,
    ),
    BaselineRow(
        "001-pidccc-rms", "001", "screw curve, SMC+DOB axes, PID-CCC, RMS contour error",
        24.6, "um", "xyz_pmlsm", "helix", _scalar("rms_contour_error", UM), ccc=True,
    ),
    BaselineRow(
        "002-track-x", "002", "x max tracking error, no friction compensation (experiment)",
        3.98, "um", "lugre_linear_motor", "bspline_complex",
        _column("max_tracking_error", 0, UM), {"feedrate": 0.5 / 60.0}, experiment=True,
        note="002's 600 mm test path (fig. 9) is unpublished: ours runs its B-spline at the "
        "same 500 mm/min. 002's table-1 LuGre breakaway (30 N) against loops a 1 ms servo "
        "rate allows (80/60 rad/s, chosen) gives tens of um at the reversals; 002's drive "
        "loops, far stiffer, are unpublished",
    ),
    BaselineRow(
        "004-circle-peak", "004", "circle R 20 mm, constant feedrate, peak error", 5.00, "um",
        "xy_servo_coulomb", "circle_r20", _scalar("max_contour_error", UM), band=("rel", 0.2),
    ),
    BaselineRow(
        "004-circle-cycle", "004", "circle R 20 mm, constant feedrate, cycle time", 2.57, "s",
        "xy_servo_coulomb", "circle_r20", _scalar("cycle_time", 1.0), band=("rel", 0.05),
    ),
    BaselineRow(
        "004-corner-peak", "004", "corner +45/-45 deg, constant feedrate, peak error", 4.476,
        "um", "xy_servo_coulomb", "corner", _scalar("max_contour_error", UM),
        {"feedrate": 0.048, "path_control": "G61"}, band=("rel", 0.2),
    ),
    BaselineRow(
        "004-corner-cycle", "004", "corner +45/-45 deg, constant feedrate, cycle time", 1.465,
        "s", "xy_servo_coulomb", "corner", _scalar("cycle_time", 1.0),
        {"feedrate": 0.048, "path_control": "G61"}, band=("rel", 0.05),
    ),
    *_gantry_rows(),
)


def fidelity_table(rows: tuple[BaselineRow, ...] = ROWS, seed: int = 0) -> list[dict[str, Any]]:
    """Measure every row ideal and on the rig; the ratio and verdict use the judged one."""
    out = []
    for row in rows:
        ideal, rig = row.measure(True, seed), row.measure(False, seed)
        ours = rig if row.experiment else ideal
        out.append({
            "row": row, "ideal": ideal, "rig": rig, "ratio": ours / row.figure,
            "verdict": row.verdict(ours),
        })
    return out


def as_markdown(table: list[dict[str, Any]]) -> str:
    """The table in Markdown (the documentation's "Machines and papers": how close)."""
    lines = [
        "| paper | row | paper's figure | ours, ideal | ours, rig | ratio | band | verdict |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for t in table:
        r: BaselineRow = t["row"]
        judged = "rig" if r.experiment else "ideal"
        lines.append(
            f"| {r.paper} | {r.what} | {r.figure:g} {r.unit} | {_fmt(t['ideal'])} | "
            f"{_fmt(t['rig'])} | {t['ratio']:.2f} ({judged}) | {r.band_text()} | "
            f"{t['verdict']} |"
        )
    return "\n".join(lines)


def _fmt(x: float) -> str:
    return f"{x:.4g}" if np.isfinite(x) else "inf"
