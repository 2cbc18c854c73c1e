import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from contour_gym.loop import simulate_axis
from contour_gym.plant import (
    AxisParams,
    CoulombFriction,
    Disturbance,
    LuGreFriction,
    Ripple,
    Stage,
    StribeckFriction,
)
from contour_gym.plant import _kernel as K
from contour_gym.plant.friction import stribeck
from contour_gym.plant.stage import Contour, disturbance_row, friction_row
from contour_gym.presets import PRESETS, get_preset


def run_axis(axis: AxisParams, u, ts=1e-3, nsub=1, n=1000, x0=0.0, v0=0.0, seed=None):
    """Drive one axis with control u(k) (callable) and return positions and velocities."""
    controls = np.array([u(k) for k in range(n)], dtype=float)
    noise = np.random.default_rng(seed).standard_normal(n) if seed is not None else None
    xs, vs, _ = simulate_axis(axis, controls, ts=ts, substeps=nsub, x0=x0, v0=v0, noise=noise)
    return xs, vs


def test_zoh_matches_ode_solution():
    axis = AxisParams("x", mass=2.0, damping=3.0, stiffness=50.0, force_constant=4.0, u_max=10.0)
    ts, n = 1e-3, 500
    u = lambda k: math.sin(0.01 * k)  # noqa: E731 - held constant over each tick
    xs, _ = run_axis(axis, u, ts=ts, n=n)
    x, v = 0.0, 0.0

    def rhs(t, y, uk):
        return [y[1], (4.0 * uk - 3.0 * y[1] - 50.0 * y[0]) / 2.0]

    for k in range(n):
        sol = solve_ivp(
            rhs,
            (0, ts),
            [x, v],
            args=(u(k),),
            rtol=1e-12,
            atol=1e-15,
        )
        x, v = sol.y[:, -1]
    assert xs[-1] == pytest.approx(x, abs=1e-12)


def test_current_loop_is_first_order_lag():
    axis = AxisParams("x", mass=1.0, damping=0.0, force_constant=1.0, u_max=10.0, current_tau=0.01)
    _, _, st = simulate_axis(axis, np.ones(10), ts=1e-3)
    assert st[K.ST.i] == pytest.approx(1.0 - math.exp(-0.01 / 0.01), rel=1e-12)


def test_coulomb_stiction_holds_below_breakaway_and_moves_above():
    axis = AxisParams(
        "x",
        mass=1.0,
        damping=0.0,
        force_constant=1.0,
        u_max=100.0,
        friction=CoulombFriction(fc=2.0, fs=3.0),
    )
    xs, vs = run_axis(axis, lambda k: 2.9, n=200)
    assert np.all(xs == 0.0) and np.all(vs == 0.0)
    xs, vs = run_axis(axis, lambda k: 3.1, n=200)
    assert xs[-1] > 0 and np.all(vs >= 0)


def test_coulomb_coasting_stops_at_analytic_distance_without_reversing():
    axis = AxisParams(
        "x", mass=2.0, damping=0.0, force_constant=1.0, u_max=1.0, friction=CoulombFriction(fc=4.0)
    )
    xs, vs = run_axis(axis, lambda k: 0.0, n=2000, v0=1.0)
    assert np.all(vs >= 0.0)
    assert vs[-1] == 0.0
    assert xs[-1] == pytest.approx(1.0**2 * 2.0 / (2 * 4.0), rel=1e-3)


def test_stribeck_curve_matches_003_form():
    fr = StribeckFriction(fc=1.0, fs=2.0, vs=0.1, delta=2.0, fv=3.0)
    row = friction_row(AxisParams("x", mass=1, damping=0, force_constant=1, u_max=1, friction=fr))
    for v in (-0.3, -0.05, 0.02, 0.5):
        want = (1.0 + 1.0 * math.exp(-((abs(v) / 0.1) ** 2)) + 3.0 * abs(v)) * math.copysign(1, v)
        assert stribeck.kinetic(row[None], 0, v) == pytest.approx(want, rel=1e-12)


def test_lugre_reaches_stribeck_steady_state():
    # a huge mass keeps the velocity ~constant; in steady sliding the bristle deflection
    # settles at z = g(v)/sigma0, i.e. F = g(v) + sigma2 v (002 eqs. 2-3)
    fr = LuGreFriction(sigma0=560.0, sigma1=300.0, sigma2=4.0, fc=20.0, fs=30.0, vs=0.5)
    axis = AxisParams("x", mass=1e9, damping=0.0, force_constant=1.0, u_max=1.0, friction=fr)
    for v0 in (0.1, -0.4, 1.0):
        # 20 s: > 35 bristle time constants g/(sigma0 |v|)
        _, _, st = simulate_axis(axis, np.zeros(20000), ts=1e-3, substeps=4, v0=v0)
        v = st[K.ST.v]
        assert v == pytest.approx(v0, rel=1e-4)
        g = 20.0 + 10.0 * math.exp(-((v / 0.5) ** 2))
        assert st[K.ST.z0] == pytest.approx(math.copysign(g / 560.0, v), rel=1e-6)


def test_ripple_force_formula():
    rip = Ripple(sin_amp=(1.0, 0.5), cos_amp=(0.2, 0.0), wavenumber=(10.0, 20.0))
    x = 0.123
    want = math.sin(1.23) + 0.2 * math.cos(1.23) + 0.5 * math.sin(2.46)
    assert rip.harmonic
    for harmonic in (False, True):
        got = K.ripple_force(rip.as_array()[None], 0, 2, harmonic, x)
        assert got == pytest.approx(want, rel=1e-12)


def test_harmonic_ripple_recurrence_matches_the_direct_sum():
    """The 003 gantry's six harmonics by recurrence equal the direct sum within a few ulp."""
    w1 = 2.0 * math.pi / 0.032
    rip = Ripple(
        sin_amp=tuple(1.0 / j for j in range(1, 7)),
        cos_amp=tuple(0.5 / j for j in range(1, 7)),
        wavenumber=tuple(2.0 * math.pi * j / 0.032 for j in range(1, 7)),
    )
    assert rip.harmonic
    table = rip.as_array()[None]
    for x in np.linspace(-0.3, 0.3, 1001):
        direct = K.ripple_force(table, 0, 6, False, x)
        fast = K.ripple_force(table, 0, 6, True, x)
        assert abs(fast - direct) <= 1e-12 * 3.0, (x, fast, direct)
    assert not Ripple((1.0, 1.0), (0.0, 0.0), (w1, 2.5 * w1)).harmonic
    assert not Ripple((1.0,), (0.0,), (0.0,)).harmonic


def test_random_disturbance_is_seeded_and_has_the_given_std():
    d = Disturbance(random_std=3.0, random_bandwidth=50.0)
    row = disturbance_row(AxisParams("x", 1, 0, 1, 1, disturbance=d), 1e-3)

    def draw(seed):
        st = np.zeros((1, K.STATE.size))
        rng = np.random.default_rng(seed)
        rows, n = row[None], 40000
        return np.array(
            [K.disturbance_force(rows, st, 0, k * 1e-3, rng.standard_normal()) for k in range(n)]
        )

    a, b, c = draw(1), draw(1), draw(2)
    assert np.array_equal(a, b) and not np.array_equal(a, c)
    assert a[1000:].std() == pytest.approx(3.0, rel=0.1)


def test_rotary_conversion():
    a = AxisParams.from_rotary(
        "x",
        inertia=0.01,
        viscous=0.1,
        torque_constant=1.0,
        lead=0.01,
        coulomb_torque=0.2,
        u_max=5.0,
    )
    n = 2 * math.pi / 0.01
    assert a.mass == pytest.approx(0.01 * n * n)
    assert a.damping == pytest.approx(0.1 * n * n)
    assert a.force_constant == pytest.approx(n)
    assert a.friction == CoulombFriction(0.2 * n)


@pytest.mark.parametrize("name", PRESETS)
def test_presets_build_with_notes(name):
    pr = get_preset(name)
    assert pr.stage.notes and pr.paper in pr.stage.notes[:3] + pr.stage.notes
    assert len(pr.axis_gains) == pr.stage.n_axes


@pytest.mark.parametrize(
    "kwargs, needle",
    [
        (dict(mass=-1.0), "x.mass"),
        (dict(mass=float("nan")), "x.mass"),
        (dict(force_constant=0.0), "x.force_constant"),
        (dict(u_max=-2.0), "x.u_max"),
    ],
)
def test_bad_axis_parameters_raise(kwargs, needle):
    base = dict(mass=1.0, damping=0.0, force_constant=1.0, u_max=1.0)
    base.update(kwargs)
    with pytest.raises(ValueError, match=needle):
        AxisParams("x", **base)


def test_bad_stage_and_preset_inputs():
    ax = AxisParams("x", mass=1.0, damping=0.0, force_constant=1.0, u_max=1.0)
    with pytest.raises(ValueError, match="ts"):
        Stage("s", (ax, ax), (Contour((0, 1)),), ts=-1e-3)
    with pytest.raises(ValueError, match="out of range"):
        Stage("s", (ax, ax), (Contour((0, 2)),), ts=1e-3)
    with pytest.raises(ValueError, match="xy_dc_servo"):
        get_preset("no_such_machine")
    with pytest.raises(ValueError, match="fs"):
        StribeckFriction(fc=2.0, fs=1.0, vs=0.1)
    with pytest.raises(ValueError, match="sigma0"):
        LuGreFriction(sigma0=-1, sigma1=1, sigma2=0, fc=1, fs=2, vs=0.1)
