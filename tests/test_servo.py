"""Axis controllers: registry, laws, batching, failure isolation, defaults, bad input."""

import dataclasses
import math

import numpy as np
import pytest

from contour_gym.api import make_scenario
from contour_gym.loop import ServoLoop
from contour_gym.loop.state import REASON_DIVERGED, REASON_NOT_IN_POSITION
from contour_gym.motion import Interpolator
from contour_gym.paths import circle
from contour_gym.plant import Disturbance, LuGreFriction
from contour_gym.presets import PRESETS, get_preset
from contour_gym.servo import (
    CONTROLLERS,
    AxisControllers,
    build_controller,
    compensation,
    controller_options,
    smc,
    smc_defaults,
    two_dof_pid,
    two_dof_pid_params,
    two_dof_pid_values,
)

NAMES = ("pid", "two_dof_pid", "smc_dob", "smc", "pd_robust")
# one absurd gain per kind (by its schema's name): makes the sampled loop unstable
ABSURD = {"pid": "kd", "two_dof_pid": "kd", "smc_dob": "reaching", "smc": "reaching",
          "pd_robust": "kd"}


def test_registry_holds_the_issue_names():
    assert set(NAMES) <= set(CONTROLLERS)
    assert "observer_gain" in controller_options("smc_dob")
    assert "friction" in controller_options("pd_robust")


@pytest.mark.parametrize("name", NAMES)
def test_batch_members_with_equal_parameters_equal_batch_of_one_bit_for_bit(name):
    sc = make_scenario("xyz_pmlsm")  # random disturbances: the seeded part of the loop
    one = sc.loop(axis_controller=name, record=True)
    one.reset([5])
    one.step(400)
    many = sc.loop(axis_controller=name, batch_size=3, record=True)
    many.reset([5, 5, 5])
    many.step(400)
    t1, t3 = one.trace(), many.trace()
    for b in range(3):
        assert np.array_equal(t3.u[b], t1.u[0])
        assert np.array_equal(t3.x[b], t1.x[0])
        assert np.array_equal(many.ctrl_s[b], one.ctrl_s[0])


@pytest.mark.parametrize("friction", ["feedforward", "feedback", "feedback_static"])
def test_friction_compensation_batches_bit_for_bit(friction):
    sc = make_scenario("lugre_linear_motor")
    opts = {"friction": friction}
    one = sc.loop(axis_controller="smc_dob", controller_options=opts)
    one.step(500)
    many = sc.loop(axis_controller="smc_dob", controller_options=opts, batch_size=2)
    many.step(500)
    assert np.array_equal(many.ax_s[1], one.ax_s[0])
    assert np.array_equal(many.ctrl_s[0], one.ctrl_s[0])


def test_observer_and_friction_feedforward_do_not_both_cancel_the_friction():
    sc = make_scenario("lugre_linear_motor")
    alone = sc.loop(axis_controller="smc_dob")
    both = sc.loop(axis_controller="smc_dob", controller_options={"friction": "feedforward"})
    te_alone = alone.run()["max_tracking_error"]
    te_both = both.run()["max_tracking_error"]
    # the observer sees the compensation as part of the disturbance; counting the friction
    # twice would cost hundreds of um
    assert np.all(te_both < 3.0 * te_alone)
    assert np.all(te_both < 10e-6)


@pytest.mark.parametrize("name", NAMES)
def test_unstable_member_is_flagged_without_poisoning_others(name):
    pr = get_preset("xy_dc_servo")
    # an actuator that never saturates lets an unstable gain set really diverge
    axes = tuple(dataclasses.replace(a, u_max=1e12) for a in pr.stage.axes)
    stage = dataclasses.replace(pr.stage, axes=axes)
    path, ip = circle(0.01), Interpolator(0.03)
    loop = ServoLoop(stage, path, pr.axis_gains, ip, batch_size=3, axis_controller=name)
    params = loop.ctrl_p.copy()
    params[1, :, loop.controller.params.names.index(ABSURD[name])] = 1e9
    loop.set_controller_params(params)
    m = loop.run()
    single = ServoLoop(stage, path, pr.axis_gains, ip, axis_controller=name)
    m1 = single.run()
    assert loop.failed.tolist() == [False, True, False]
    assert np.isinf(m["max_tracking_error"][1]).all()
    for b in (0, 2):
        assert np.isfinite(loop.ax_s[b]).all()
        assert np.array_equal(m["max_tracking_error"][b], m1["max_tracking_error"][0])


# Every controller on the two hardest machines (the gantry: three axes, 10-50 um encoders,
# ripple; 004's: Coulomb friction holding the axis short); every other machine with its own
# controller. (Each pair compiles its own kernel: the full 5 x 5 matrix costs CI 8 minutes.)
_HARD = ("xyy_gantry", "xy_servo_coulomb")
STABILITY_CASES = {p: NAMES if p in _HARD else (get_preset(p).axis_controller,) for p in PRESETS}


@pytest.mark.parametrize("preset", sorted(STABILITY_CASES))
def test_default_parameters_give_a_stable_loop_on_every_preset(preset):
    sc = make_scenario(preset)  # on the rig: encoder quantisation and a one-tick delay
    for name in STABILITY_CASES[preset]:
        loop = sc.loop(axis_controller=name, batch_size=2)
        loop.reset([0, 1])
        m = loop.run()
        assert not np.any(loop.failure_reason == REASON_DIVERGED), name
        if name in ("pid", "two_dof_pid", "smc_dob"):  # integral action or an observer
            assert np.all(loop.done), name
        else:  # without either, friction may hold the axis short of the in-position band
            assert np.all(loop.done | (loop.failure_reason == REASON_NOT_IN_POSITION)), name
        # bounded: below 4 mm everywhere (the presets' PID peaks at 1-3.1 mm on its start-up
        # transient, the gantry's highest with its 10 um encoders), and no limit cycle beyond
        # the PID's scale
        assert np.all(m["max_tracking_error"] < 4e-3), (name, m["max_tracking_error"])
        assert np.all(np.isfinite(m["chattering"])), name


def test_two_dof_pid_implements_003_eq_34():
    pr = get_preset("xyy_gantry")
    ctl = AxisControllers("two_dof_pid", pr.stage, pr.axis_gains, alpha=0.2, beta=0.5)
    kp, ti, td = ctl.params[0, 0, two_dof_pid.C.kp], *two_dof_pid_values(pr.axis_gains)[0, 1:3]
    ts, r, rd, y0, y1 = pr.stage.ts, 1e-3, 2e-3, 0.0, 1e-7
    u0 = ctl.step(r, rd, 0.0, y0)[0, 0]
    assert u0 == pytest.approx(kp * ((1 - 0.2) * r - y0 + (r - y0) * ts / ti + td * (1 - 0.5) * rd))
    u1 = ctl.control(r, rd, 0.0, y1)[0, 0]
    integ = (r - y0) * ts + (r - y1) * ts
    want = kp * ((1 - 0.2) * r - y1 + integ / ti + td * ((1 - 0.5) * rd - (y1 - y0) / ts))
    assert u1 == pytest.approx(want, rel=1e-12)


def test_smc_law_with_boundary_layer():
    pr = get_preset("xyz_pmlsm")
    ctl = AxisControllers("smc", pr.stage, pr.axis_gains)
    d = smc_defaults(pr.stage, pr.axis_gains, observer=False)
    ax = pr.stage.axes[0]
    a, b = ax.damping / ax.mass, ax.force_constant / ax.mass
    c, lam, eta, phi = d["c"][0], d["reaching"][0], d["eta"][0], d["phi"][0]
    for e, rd in ((1e-6, 0.0), (1e-3, 0.01), (-1e-3, -0.01)):  # inside and outside the layer
        u = ctl.control(e, rd, 0.3, 0.0)[0, 0]
        surf = rd + c * e
        want = (0.3 + a * 0.0 + c * rd + lam * surf + eta * np.clip(surf / phi, -1, 1)) / b
        assert u == pytest.approx(want, rel=1e-12)


def test_disturbance_observer_estimates_a_constant_force():
    pr = get_preset("xyz_pmlsm")
    force = 5.0
    step = Disturbance(step_amp=force)
    axes = tuple(dataclasses.replace(a, disturbance=step) for a in pr.stage.axes)
    stage = dataclasses.replace(pr.stage, axes=axes)
    sc = make_scenario(dataclasses.replace(pr, stage=stage), ideal=True)  # the observer law
    with_dob = sc.loop(axis_controller="smc_dob")
    with_dob.step(2000)
    masses = np.array([a.mass for a in axes])
    np.testing.assert_allclose(with_dob.ctrl_s[0, :, smc.S.d_hat], force / masses, rtol=0.01)
    without = sc.loop(axis_controller="smc")
    without.step(200)
    assert np.all(without.ctrl_s[..., smc.S.d_hat] == 0.0)


def test_two_dof_pid_params_maps_the_tunable_numbers_by_name():
    pr = get_preset("xyy_gantry")
    _, base, _ = build_controller("two_dof_pid", pr.stage, pr.axis_gains, 4)
    rng = np.random.default_rng(0)
    vals = rng.uniform([1, 0.01, 0, 0, 0], [100, 1, 0.01, 1, 1], (4, 3, 5))
    vals[0, 0, 1] = math.inf  # no integral
    rows = two_dof_pid_params(vals)
    c = two_dof_pid.C
    assert rows.shape == (4, 3, two_dof_pid.PARAMS.size)
    np.testing.assert_array_equal(rows[..., c.kp], vals[..., 0])
    np.testing.assert_allclose(rows[..., c.ki], vals[..., 0] / vals[..., 1])
    np.testing.assert_allclose(rows[..., c.kd], vals[..., 0] * vals[..., 2])
    np.testing.assert_array_equal(rows[..., c.alpha], vals[..., 3])
    np.testing.assert_array_equal(rows[..., c.beta], vals[..., 4])
    assert rows[0, 0, c.ki] == 0.0
    # the preset's PID expressed in the five numbers gives the builder's default rows
    default = two_dof_pid_params(two_dof_pid_values(pr.axis_gains))
    np.testing.assert_allclose(default, base[0])


def test_optimiser_population_sets_per_member_two_dof_parameters():
    sc = make_scenario("xyy_gantry")
    vals = np.repeat(two_dof_pid_values(sc.preset.axis_gains)[None], 2, axis=0)
    vals[..., 3] = sc.preset.controller_options["alpha"]  # 003's published alpha, beta
    vals[..., 4] = sc.preset.controller_options["beta"]
    vals[1, :, 4] = 0.8  # beta: member 1 differs
    loop = sc.loop(axis_controller="two_dof_pid", batch_size=2)
    loop.set_controller_params(two_dof_pid_params(vals))
    loop.step(300)
    alone = sc.loop(axis_controller="two_dof_pid", controller_options={"beta": 0.8})
    alone.step(300)
    assert np.array_equal(loop.ax_s[1], alone.ax_s[0])
    assert not np.array_equal(loop.ax_s[0], loop.ax_s[1])


def test_bad_input_raises_clear_value_errors():
    pr = get_preset("xyz_pmlsm")
    st, g = pr.stage, pr.axis_gains
    with pytest.raises(ValueError, match="axis_controller"):
        build_controller("lqr", st, g, 1)
    with pytest.raises(ValueError, match="axis_controller"):
        make_scenario("xyz_pmlsm").loop(axis_controller="nope")
    with pytest.raises(ValueError, match="unknown option"):
        build_controller("pid", st, g, 1, eta=1.0)
    for name, bad in (
        ("smc_dob", {"mass": -1.0}),
        ("smc", {"mass": [4.0, 0.0, 2.0]}),
        ("pd_robust", {"force_constant": 0.0}),
        ("smc_dob", {"phi": 0.0}),
        ("smc", {"phi": -1e-3}),
        ("smc_dob", {"c": 0.0}),
        ("smc_dob", {"eta": -1.0}),
        ("pd_robust", {"kp": -1.0}),
        ("two_dof_pid", {"kp": 0.0}),
        ("two_dof_pid", {"ti": -1.0}),
        ("smc_dob", {"observer_gain": 2.0 / st.ts}),
        ("smc", {"observer_gain": 10.0}),
        ("smc_dob", {"c": [1.0, 2.0]}),
        ("pid", {"friction": "magic"}),
        ("pid", {"friction": "feedforward"}),  # no LuGre friction on these axes
        ("pid", {"friction": "feedforward", "friction_model": [None]}),
    ):
        with pytest.raises(ValueError):
            build_controller(name, st, g, 1, **bad)
    with pytest.raises(ValueError, match="two_dof_pid"):
        two_dof_pid_params(np.ones((3, 4)))
    with pytest.raises(ValueError, match="Kp > 0"):
        two_dof_pid_params([[0.0, 1.0, 0.0, 0.0, 0.0]])
    ctl = AxisControllers("smc_dob", st, g, batch_size=2)
    with pytest.raises(ValueError, match="y"):
        ctl.step(0.0, 0.0, 0.0, [[0.0, np.nan, 0.0], [0.0, 0.0, 0.0]])
    with pytest.raises(ValueError, match="broadcast"):
        ctl.control(0.0, 0.0, 0.0, np.zeros(4))
    with pytest.raises(ValueError, match="batch_size"):
        AxisControllers("pid", st, g, batch_size=0)


def test_axis_controllers_saturate_and_reset():
    pr = get_preset("lugre_linear_motor")
    model = LuGreFriction(sigma0=500.0, sigma1=250.0, sigma2=4.0, fc=20.0, fs=28.0, vs=0.4)
    ctl = AxisControllers(
        "pid", pr.stage, pr.axis_gains, batch_size=2, friction="feedforward", friction_model=model
    )
    u = ctl.step(1.0, 0.01, 0.0, 0.0)  # 1 m error: saturates
    assert np.all(np.abs(u) == [a.u_max for a in pr.stage.axes])
    # the bristles of the feed-forward model moved
    assert np.all(ctl.comp_state[..., compensation.S.z] != 0.0)
    ctl.reset()
    assert not ctl.state.any() and not ctl.comp_state.any()
