"""The CCC laws' release while the reference waits for the axes (contour_gym.ccc)."""

from __future__ import annotations

import math
import pathlib

import numpy as np
import pytest

from agents import ccc_laws
from agents.evaluate import run_policy
from agents.policies import make
from contour_gym.api import make_scenario, run_trace
from contour_gym.ccc import CCC_LAWS, RELEASE_TIME, CCCLaw, keep_state, release_integral
from contour_gym.params import state_schema
from contour_gym.paths import from_gcode, polyline
from contour_gym.servo.pid import STATE as PID_STATE

PART = pathlib.Path(__file__).parent / "data" / "gcode" / "part_2d.ngc"


def test_the_release_bleeds_the_integral_and_the_default_keeps_the_state() -> None:
    ts = 1e-3
    s = np.array([[2.0e-6, 1.0e-6, 1.0]])
    release_integral.py_func(None, s, None, 0, 0, ts)
    assert s[0, PID_STATE.col.integral] == 2.0e-6 * math.exp(-ts / RELEASE_TIME)
    assert s[0, 1:].tolist() == [1.0e-6, 1.0]  # the previous error and the start flag stay
    before = s.copy()
    keep_state.py_func(None, s, None, 0, 0, ts)
    assert np.array_equal(s, before)
    assert CCCLaw.__dataclass_fields__["release"].default is keep_state


def test_every_built_in_law_releases_its_integral() -> None:
    for name in ("pid", "fuzzy_pid", "adaptive_fuzzy_pid"):
        law = CCC_LAWS.get(name)
        assert law.release is release_integral, name
        assert law.state.names[PID_STATE.col.integral] == "integral", name


def test_a_law_whose_state_has_no_integral_cannot_release_one() -> None:
    law = ccc_laws.FUZZY_PID
    no_integral = state_schema("no integral", "gain", "e_prev")
    with pytest.raises(ValueError, match="release_integral bleeds state column 0"):
        CCCLaw("bad", law.params, no_integral, law.output, law.commit, release=release_integral)


@pytest.mark.parametrize("policy", ["pid_ccc", "fuzzy_pid_ccc"])
def test_an_integrating_ccc_comes_in_position_with_a_nearest_point_estimator(policy: str) -> None:
    # 002's machine, pre-compensation, the exact nearest point: holding its integral, each of
    # these CCCs kept the axes off the part's waiting points and never finished (2026-11-29)
    path = from_gcode(PART.read_text(), name="part_2d")
    m = run_policy({"id": "contour_gym/CCC-v1", "plant": "lugre_linear_motor", "path": path,
                    "estimator": "ground_truth", "path_tolerance": 1.29e-5},
                   make(policy))
    assert m["finished"] and not m["failed"]
    assert m["max_contour_error"] < 100e-6


def _zigzag(turn_deg: float, rotate_deg: float) -> np.ndarray:
    # three 25 mm legs turning back by turn_deg, left then right, the whole rotated
    dy = 25.0 * math.tan(math.radians(180.0 - turn_deg))
    c, s = math.cos(math.radians(rotate_deg)), math.sin(math.radians(rotate_deg))
    legs = np.array([[0.0, 0.0], [25.0, 0.0], [0.0, dy], [25.0, 2.0 * dy]]) * 1e-3
    return legs @ np.array([[c, s], [-s, c]])


@pytest.mark.parametrize(("turn", "rotate"), [(176.0, -30.0), (179.0, 210.0)])
def test_a_ccc_on_the_nearest_point_is_not_drawn_back_along_a_reversed_leg(
    turn: float, rotate: float
) -> None:
    # 002's machine, the exact nearest point, the PID CCC: after the reversal the machine's
    # foot stayed on the leg it had left and the CCC pulled it back along that leg, 1.47 mm
    # off the reference's leg (176 degrees) or failing in position (179) until the law stood
    # aside while its foot retraced a leg running against the reference (contour_gym.ccc)
    sc = make_scenario("lugre_linear_motor", polyline(_zigzag(turn, rotate)),
                       estimator="ground_truth")
    peaks, lags = [], []
    for gains in (None, sc.preset.ccc_gains.as_tuple()):
        m, tr = run_trace(sc, gains)
        assert math.isfinite(m["cycle_time"]), gains
        peaks.append(m["max_contour_error"])
        lags.append(np.nanmax(np.linalg.norm(tr.x[0, :, :2] - tr.r[0, :, :2], axis=1)))
    assert peaks[1] < peaks[0]  # the CCC helps (drawn back: 1473 against 143 um)
    assert lags[1] < 1.1 * lags[0]  # and lags its reference as the axes alone do (drawn: 3 mm)
