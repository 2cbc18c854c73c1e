"""The papers' axis-control results on fixed seeds (benchmarks/axis_control.py prints them)."""

import numpy as np
import pytest

from agents.identify import friction_sweep, identify_friction
from contour_gym.api import make_scenario
from contour_gym.servo import smc_defaults

SEEDS = [0, 1, 2]


def run(scenario, name, seeds=SEEDS, **options):
    loop = scenario.loop(axis_controller=name, controller_options=options, batch_size=len(seeds))
    loop.reset(seeds)
    m = loop.run()
    assert not loop.failed.any()
    return m["max_tracking_error"], m["chattering"]


@pytest.fixture(scope="module")
def pmlsm():
    sc = make_scenario("xyz_pmlsm")  # 001's 3-axis PMLSM with random + sinusoidal disturbances
    small_eta = smc_defaults(sc.preset.stage, sc.preset.axis_gains, observer=True)["eta"]
    return {
        "smc_dob": run(sc, "smc_dob"),
        "smc": run(sc, "smc"),
        "smc_small_eta": run(sc, "smc", eta=small_eta),
        "pd_robust": run(sc, "pd_robust"),
    }


def test_001_smc_without_observer_needs_the_larger_switching_gain(pmlsm):
    te_dob = pmlsm["smc_dob"][0].max(axis=1)
    te_small = pmlsm["smc_small_eta"][0].max(axis=1)
    assert np.all(te_small > 3.0 * te_dob)


def test_001_observer_halves_control_variation_at_equal_or_lower_max_tracking_error(pmlsm):
    (te_dob, tv_dob), (te_smc, tv_smc) = pmlsm["smc_dob"], pmlsm["smc"]
    assert np.all(tv_dob <= 0.5 * tv_smc)
    assert np.all(te_dob.max(axis=1) <= te_smc.max(axis=1))


def test_001_smc_dob_tracks_better_than_robust_pd(pmlsm):
    te_dob, te_pd = pmlsm["smc_dob"][0], pmlsm["pd_robust"][0]
    assert np.all(te_dob < te_pd)


def test_002_friction_feedforward_beats_no_and_traditional_compensation():
    ident = identify_friction(friction_sweep(), "improved_foa", seed=0)
    sc = make_scenario("lugre_linear_motor")  # B-spline path at 1400 mm/min
    # the preset's two axes share table 1's friction; the x-axis identification serves both
    none, _ = run(sc, "pid", seeds=[0])
    ff, _ = run(sc, "pid", seeds=[0], friction="feedforward", friction_model=ident.friction)
    fb, _ = run(sc, "pid", seeds=[0], friction="feedback", friction_model=ident.friction)
    assert np.all(ff <= 0.75 * none)
    assert np.all(ff < fb)
