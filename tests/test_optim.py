"""Tests of agents.optim: accuracy on test functions, the papers' claims, contract and inputs."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from agents.optim import OPTIMIZERS, OptimResult, minimize, options_of
from agents.optim.abc import abc_probabilities, iabc_probabilities, rank_fitness
from agents.optim.foa import crossover_probability, dynamic_step
from agents.optim.pso import improved_coefficients

NAMES = ("pso", "improved_pso", "abc", "improved_abc", "foa", "improved_foa", "de", "cma")


def sphere(x: np.ndarray) -> np.ndarray:
    return np.sum(x**2, axis=1)


def rosenbrock(x: np.ndarray) -> np.ndarray:
    return np.sum(100.0 * (x[:, 1:] - x[:, :-1] ** 2) ** 2 + (1.0 - x[:, :-1]) ** 2, axis=1)


def rastrigin(x: np.ndarray) -> np.ndarray:
    return 10.0 * x.shape[1] + np.sum(x**2 - 10.0 * np.cos(2.0 * np.pi * x), axis=1)


# name -> (function, bounds); the sphere's box is off-centre so a centre bias does not help
PROBLEMS: dict[str, tuple[Callable[[np.ndarray], np.ndarray], list[list[float]]]] = {
    "sphere5": (sphere, [[-3.0, 7.0]] * 5),
    "rosenbrock2": (rosenbrock, [[-2.0, 2.0]] * 2),
    "rosenbrock5": (rosenbrock, [[-2.0, 2.0]] * 5),
    "rastrigin5": (rastrigin, [[-5.12, 5.12]] * 5),
}


class Checked:
    """A batch objective that asserts every point it is given lies inside the box."""

    def __init__(self, fn: Callable[[np.ndarray], np.ndarray], bounds: object) -> None:
        box = np.asarray(bounds, dtype=float)
        self.fn, self.low, self.high = fn, box[:, 0], box[:, 1]
        self.evals = 0

    def __call__(self, x: np.ndarray) -> np.ndarray:
        assert x.ndim == 2 and x.shape[1] == self.low.size, x.shape
        assert np.all(x >= self.low) and np.all(x <= self.high), "point outside the bounds"
        self.evals += x.shape[0]
        return self.fn(x)


def run(name: str, problem: str, seed: int, population: int, iterations: int) -> OptimResult:
    fn, bounds = PROBLEMS[problem]
    checked = Checked(fn, bounds)
    res = minimize(name, checked, bounds, population=population, iterations=iterations, seed=seed)
    assert checked.evals == res.nfev == population * (iterations + 1)
    return res


def median_fun(name: str, problem: str, seeds: range, population: int, iterations: int) -> float:
    return float(np.median([run(name, problem, s, population, iterations).fun for s in seeds]))


# ---------------------------------------------------------------------------------------------
# Accuracy: median final fitness of seeds 0-2 with 30 members x 100 generations (3030 evals)
# must be below these tolerances (global minimum 0 everywhere). Each is above the measured
# median with margin and below the median of pure random search with the same budget (last
# row), so an optimiser that stops optimising fails.
TOLERANCE: dict[str, tuple[float, float, float, float]] = {
    #               sphere5  rosenbrock2 rosenbrock5 rastrigin5
    "pso": (1e-5, 1e-4, 3.0, 3.0),
    "improved_pso": (1e-10, 1e-6, 4.0, 10.0),
    # abc rosenbrock2 was 1e-2 with Karaboga's 1 / (1 + f); with the rank fitness seeds 0-2
    # give 0.009, 0.020, 0.015 (seeds 0-39: median 0.0055, with 1 / (1 + f) 0.0032): the
    # one-coordinate move crawls along the curved valley and the final value scatters widely
    "abc": (1e-7, 1.8e-2, 1.0, 0.05),
    "improved_abc": (1e-3, 1e-2, 1.0, 0.5),
    "foa": (0.3, 5e-3, 4.0, 15.0),
    "improved_foa": (1e-6, 1e-5, 3.0, 20.0),
    "de": (1e-9, 1e-15, 0.05, 3.0),
    "cma": (1e-12, 1e-15, 1e-5, 3.0),
}
RANDOM_SEARCH_MEDIAN = (2.6, 0.0194, 27.2, 23.5)  # measured, seeds 0-2, 3030 uniform points


def test_tolerances_are_stricter_than_random_search() -> None:
    for name, row in TOLERANCE.items():
        assert all(t < r for t, r in zip(row, RANDOM_SEARCH_MEDIAN, strict=True)), name
    for problem, expected in zip(PROBLEMS, RANDOM_SEARCH_MEDIAN, strict=True):
        fn, bounds = PROBLEMS[problem]
        box = np.asarray(bounds)
        best = []
        for seed in range(3):
            u = np.random.default_rng(seed).random((3030, box.shape[0]))
            best.append(fn(box[:, 0] + u * (box[:, 1] - box[:, 0])).min())
        assert np.median(best) == pytest.approx(expected, rel=0.05, abs=1e-3)


@pytest.mark.parametrize("problem", list(PROBLEMS))
@pytest.mark.parametrize("name", NAMES)
def test_reaches_tolerance(name: str, problem: str) -> None:
    tol = TOLERANCE[name][list(PROBLEMS).index(problem)]
    assert median_fun(name, problem, range(3), population=30, iterations=100) <= tol


# ---------------------------------------------------------------------------------------------
# The papers' claims: the improved algorithm beats its baseline on the median of seeds 0-4 at
# paper 000's budget (50 members, 100 generations). Measured medians are in the reasons.
# improved_pso vs pso on rosenbrock5 is left out: over seeds 0-19 it is a tie (median 1.08 vs
# 1.10, better on 8 of 20 seeds), so a pass on seeds 0-4 would be luck, not a claim.
CLAIMS = [
    ("pso", "improved_pso", "rosenbrock2", None),
    (
        "pso",
        "improved_pso",
        "rastrigin5",
        "measured: improved_pso 2.98 vs pso 1.06; c1 + c2 = 1.5 contracts the swarm early",
    ),
    ("foa", "improved_foa", "rosenbrock2", None),
    ("foa", "improved_foa", "rosenbrock5", None),
    (
        "foa",
        "improved_foa",
        "rastrigin5",
        "measured: improved_foa 14.9 vs foa 6.3; the shrinking step settles in a local minimum "
        "and Cauchy mutants of the swarm location rarely find a better basin",
    ),
]


@pytest.mark.parametrize(
    ("baseline", "improved", "problem"),
    [
        pytest.param(b, i, p, marks=pytest.mark.xfail(reason=why, strict=True) if why else ())
        for b, i, p, why in CLAIMS
    ],
)
def test_improved_beats_baseline(baseline: str, improved: str, problem: str) -> None:
    base = median_fun(baseline, problem, range(5), population=50, iterations=100)
    better = median_fun(improved, problem, range(5), population=50, iterations=100)
    assert better < base


# ---------------------------------------------------------------------------------------------
# Contract


@pytest.mark.parametrize("name", NAMES)
def test_determinism_same_seed_same_bits(name: str) -> None:
    fn, bounds = PROBLEMS["rastrigin5"]
    kw = {"population": 12, "iterations": 15}
    first = minimize(name, fn, bounds, seed=3, keep_population=True, **kw)
    again = minimize(name, fn, bounds, seed=3, keep_population=True, **kw)
    given_rng = minimize(
        name, fn, bounds, seed=np.random.default_rng(3), keep_population=True, **kw
    )
    other = minimize(name, fn, bounds, seed=4, keep_population=True, **kw)
    for res in (again, given_rng):
        assert res.x.tobytes() == first.x.tobytes()
        assert res.history.tobytes() == first.history.tobytes()
        assert res.population_history is not None and first.population_history is not None
        assert res.population_history.tobytes() == first.population_history.tobytes()
        assert res.fun == first.fun
    assert other.history.tobytes() != first.history.tobytes()


class FirstCall:
    """An objective that keeps the points of its first call (generation 0)."""

    def __init__(self, fn: Callable[[np.ndarray], np.ndarray]) -> None:
        self.fn, self.first = fn, None

    def __call__(self, x: np.ndarray) -> np.ndarray:
        if self.first is None:
            self.first = x.copy()
        return self.fn(x)


def needle(x: np.ndarray) -> np.ndarray:
    """0 within 1e-9 of (0.3, -1.2, 2.5), 1 elsewhere: no search finds it by chance."""
    return np.where(np.all(np.abs(x - NEEDLE) < 1e-9, axis=1), 0.0, 1.0)


NEEDLE = np.array([0.3, -1.2, 2.5])


@pytest.mark.parametrize("name", NAMES)
def test_start_points_open_generation_zero_and_the_result_is_never_worse(name: str) -> None:
    bounds = [[0.0, 1.0], [-2.0, 2.0], [0.0, 2.5]]  # the needle's last coordinate on a wall
    starts = np.array([[0.9, 1.0, 0.1], NEEDLE])
    seeded, plain = FirstCall(needle), FirstCall(needle)
    kw: dict[str, Any] = {"population": 8, "iterations": 3, "seed": 5}
    res = minimize(name, seeded, bounds, x0=starts, **kw)
    assert minimize(name, plain, bounds, **kw).fun == 1.0  # the needle is not found by chance
    assert seeded.first is not None and plain.first is not None
    assert seeded.first[:2].tobytes() == starts.tobytes()  # each start as given, bit for bit
    # the other points of generation 0 are the random draws the run makes without starts
    assert seeded.first[2:].tobytes() == plain.first[2:].tobytes()
    assert res.fun == 0.0 and res.x.tobytes() == NEEDLE.tobytes()
    again = minimize(name, needle, bounds, x0=NEEDLE, **kw)  # one point as (dim,)
    assert again.fun == 0.0


@pytest.mark.parametrize(
    ("x0", "message"),
    [
        ([[0.5, 0.5]], r"x0 must have shape \(k, 3\), got shape \(1, 2\)"),
        ([[0.5, 0.5, 3.0]], r"x0\[0\] = \[0.5, 0.5, 3.0\] is not a finite point in the bounds"),
        ([[0.5, 0.5, 0.5], [0.5, np.nan, 0.5]], r"x0\[1\] = \[0.5, nan, 0.5\]"),
        ([["a", 0.5, 0.5]], "x0 must be a numeric"),
        ([[0.5] * 3] * 9, "x0 has 9 points, more than the population 8"),
    ],
)
def test_bad_start_points_are_named(x0: Any, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        minimize("improved_pso", sphere, [[0.0, 1.0]] * 3, population=8, iterations=2, seed=0,
                 x0=x0)


@pytest.mark.parametrize("name", NAMES)
def test_global_numpy_random_state_untouched(name: str) -> None:
    fn, bounds = PROBLEMS["sphere5"]
    # the legacy global generator is what cma and scipy would fall back to
    np.random.seed(1234)  # noqa: NPY002
    expected = np.random.random()  # noqa: NPY002
    np.random.seed(1234)  # noqa: NPY002
    minimize(name, fn, bounds, population=10, iterations=5, seed=0)
    assert np.random.random() == expected  # noqa: NPY002


@pytest.mark.parametrize("name", NAMES)
def test_result_contract(name: str) -> None:
    fn, bounds = PROBLEMS["rosenbrock5"]
    checked = Checked(fn, bounds)
    res = OPTIMIZERS[name](
        checked, bounds, population=10, iterations=20, seed=1, keep_population=True
    )
    assert res.name == name
    assert res.x.shape == (5,) and res.history.shape == (20,)
    assert np.all(np.diff(res.history) <= 0.0)
    assert res.history[-1] == res.fun
    assert res.nfev == checked.evals == 10 * 21
    assert res.population_history is not None and res.population_history.shape == (20, 10, 5)
    assert res.fun == pytest.approx(float(fn(res.x[None, :])[0]), rel=1e-12, abs=0.0)
    evaluated = fn(res.population_history.reshape(-1, 5))
    assert res.fun <= evaluated.min()  # best-so-far covers every generation
    with pytest.raises(ValueError, match="read-only"):
        res.x[0] = 0.0
    assert (
        minimize(name, fn, bounds, population=10, iterations=20, seed=1).population_history is None
    )


@pytest.mark.parametrize("name", NAMES)
def test_bounds_respected_when_the_minimum_is_outside(name: str) -> None:
    # sphere centred at (-10, 10, 0.5): the constrained minimum is on the walls x0=1, x1=2
    bounds = [[1.0, 4.0], [-3.0, 2.0], [0.0, 1.0]]
    centre = np.array([-10.0, 10.0, 0.5])
    checked = Checked(lambda x: np.sum((x - centre) ** 2, axis=1), bounds)
    res = minimize(name, checked, bounds, population=16, iterations=60, seed=0)
    low, high = np.asarray(bounds).T
    assert np.all(res.x >= low) and np.all(res.x <= high)
    assert res.x[0] == pytest.approx(1.0, abs=0.05)
    assert res.x[1] == pytest.approx(2.0, abs=0.05)


@settings(max_examples=8, deadline=None)
@given(
    low=st.lists(st.floats(-1e3, 1e3), min_size=1, max_size=3),
    log_width=st.floats(-3.0, 3.0),
    seed=st.integers(0, 2**32 - 1),
)
@example(low=[0.0], log_width=2.0, seed=0)  # 1-D: cma 4.5 fails there unless its std cap is off
def test_every_point_inside_any_box(low: list[float], log_width: float, seed: int) -> None:
    bounds = [[lo, lo + 10.0**log_width] for lo in low]
    for name in NAMES:
        checked = Checked(lambda x: np.sum(np.sin(x), axis=1), bounds)
        res = minimize(name, checked, bounds, population=6, iterations=4, seed=seed)
        assert checked.evals == res.nfev


def _failing(x: np.ndarray) -> np.ndarray:
    """Sphere around (1, -1, 0), NaN where x0 > 2, +inf where x1 < -2, -inf where x2 > 2."""
    f = np.sum((x - np.array([1.0, -1.0, 0.0])) ** 2, axis=1)
    f[x[:, 0] > 2.0] = np.nan
    f[x[:, 1] < -2.0] = np.inf
    f[x[:, 2] > 2.0] = -np.inf
    return f


@pytest.mark.parametrize("name", NAMES)
def test_non_finite_values_are_failures(name: str) -> None:
    bounds = [[-4.0, 4.0]] * 3
    res = minimize(name, Checked(_failing, bounds), bounds, population=12, iterations=30, seed=2)
    assert np.isfinite(res.fun) and np.all(np.isfinite(res.history))
    assert np.all(np.isfinite(res.x))
    assert res.x[0] <= 2.0 and res.x[1] >= -2.0 and res.x[2] <= 2.0
    assert res.fun < 0.5


@pytest.mark.parametrize("name", NAMES)
def test_every_member_failing_gives_inf_not_nan(name: str) -> None:
    bounds = [[-1.0, 1.0]] * 2

    def broken(x: np.ndarray) -> np.ndarray:
        return np.full(x.shape[0], np.nan)

    res = minimize(name, broken, bounds, population=8, iterations=5, seed=0)
    assert res.fun == math.inf and np.all(res.history == math.inf)
    assert np.all(np.isfinite(res.x)) and np.all(np.abs(res.x) <= 1.0)


# ---------------------------------------------------------------------------------------------
# Bad input


def test_registry_names() -> None:
    assert set(OPTIMIZERS) == set(NAMES)


def test_unknown_name_lists_accepted() -> None:
    with pytest.raises(ValueError, match="'psoo'.*accepted: abc, cma, de"):
        minimize("psoo", sphere, [[0, 1]], population=5, iterations=1, seed=0)


@pytest.mark.parametrize(
    ("bounds", "message"),
    [
        ([[0.0, np.nan]], r"bounds\[0\] = \[0.0, nan\] must be finite"),
        ([[0.0, 1.0], [-np.inf, 1.0]], r"bounds\[1\] = \[-inf, 1.0\] must be finite"),
        ([[1.0, 1.0]], r"bounds\[0\] = \[1.0, 1.0\] needs low < high"),
        ([[2.0, 1.0]], r"bounds\[0\] = \[2.0, 1.0\] needs low < high"),
        ([[-1e308, 1e308]], r"bounds\[0\] = \[-1e\+308, 1e\+308\] is wider than a float"),
        ([0.0, 1.0], r"shape \(dim, 2\).*got shape \(2,\)"),
        ([[0.0, 1.0, 2.0]], r"got shape \(1, 3\)"),
        (np.zeros((0, 2)), r"got shape \(0, 2\)"),
        ([["a", "b"]], "bounds must be a numeric"),
    ],
)
def test_bad_bounds(bounds: Any, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        minimize("pso", sphere, bounds, population=5, iterations=1, seed=0)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"population": 0}, r"population must be an int >= \d, got 0"),
        ({"population": -3}, r"population must be an int >= \d, got -3"),
        ({"population": 2.5}, r"population must be an int >= \d, got 2.5"),
        ({"population": True}, r"population must be an int >= \d, got True"),
        ({"iterations": 0}, "iterations must be an int >= 1, got 0"),
        ({"iterations": "10"}, "iterations must be an int >= 1, got '10'"),
        ({"seed": "x"}, "seed must be a non-negative int or numpy.random.Generator, got 'x'"),
        ({"seed": -1}, "seed must be .*, got -1"),
        ({"seed": 1.5}, "seed must be .*, got 1.5"),
    ],
)
def test_bad_counts_and_seed(kwargs: dict[str, Any], message: str) -> None:
    args: dict[str, Any] = {"population": 5, "iterations": 2, "seed": 0} | kwargs
    for name in NAMES:
        with pytest.raises(ValueError, match=message):
            minimize(name, sphere, [[0.0, 1.0]], **args)


@pytest.mark.parametrize(
    ("name", "minimum"), [("abc", 4), ("improved_foa", 2), ("de", 5), ("cma", 2)]
)
def test_population_minimum(name: str, minimum: int) -> None:
    with pytest.raises(ValueError, match=f"population must be an int >= {minimum}"):
        minimize(name, sphere, [[0.0, 1.0]], population=minimum - 1, iterations=2, seed=0)
    assert minimize(name, sphere, [[0.0, 1.0]], population=minimum, iterations=2, seed=0).nfev


def test_unknown_option_is_named() -> None:
    with pytest.raises(ValueError, match="unknown option.*'limt'|limt.*accepted: limit"):
        minimize("abc", sphere, [[0.0, 1.0]], population=5, iterations=2, seed=0, limt=3)
    assert "limit" in options_of("abc") and "keep_population" in options_of("cma")


@pytest.mark.parametrize(
    ("name", "option", "message"),
    [
        ("pso", {"v_max": 0.0}, "v_max must be > 0"),
        ("improved_pso", {"w_start": 0.3}, "w_start must be > w_end"),
        ("abc", {"limit": 0}, "limit must be an int >= 1, got 0"),
        ("improved_abc", {"eta2": np.nan}, "eta2 must be finite"),
        ("foa", {"radius": -1.0}, "radius must be > 0"),
        ("improved_foa", {"q1": 0.95}, "q1 must be <= q2"),
        ("improved_foa", {"p_mutation": 1.5}, r"p_mutation must be in \[0.0, 1.0\]"),
        ("de", {"recombination": 2.0}, r"recombination must be in \[0.0, 1.0\]"),
        ("cma", {"sigma0": 0.0}, "sigma0 must be > 0"),
        ("cma", {"boundary": "clip"}, "unknown boundary 'clip'; accepted: BoundPenalty"),
    ],
)
def test_bad_option_values(name: str, option: dict[str, object], message: str) -> None:
    with pytest.raises(ValueError, match=message):
        minimize(name, sphere, [[0.0, 1.0]], population=6, iterations=2, seed=0, **option)


def test_objective_with_wrong_shape_is_rejected() -> None:
    with pytest.raises(ValueError, match=r"objective must return shape \(5,\).*got shape \(5, 1\)"):
        minimize("pso", lambda x: x[:, :1] ** 2, [[0.0, 1.0]], population=5, iterations=2, seed=0)


def test_minimize_is_the_registered_function() -> None:
    fn, bounds = PROBLEMS["rosenbrock2"]
    direct = OPTIMIZERS["improved_abc"](fn, bounds, population=10, iterations=10, seed=5, eta3=0.2)
    via = minimize("improved_abc", fn, bounds, population=10, iterations=10, seed=5, eta3=0.2)
    assert direct.history.tobytes() == via.history.tobytes()


# ---------------------------------------------------------------------------------------------
# Reconstructed formulas


def test_improved_pso_coefficients() -> None:
    w0, c1_0, c2_0 = improved_coefficients(0.0)
    w1, c1_1, c2_1 = improved_coefficients(1.0)
    assert w0 == pytest.approx(0.4 + 0.5 / (1 + math.exp(-3.4)))  # 0.884
    assert w1 == pytest.approx(0.4 + 0.5 / (1 + math.exp(3.6)))  # 0.413
    w_mid, _, _ = improved_coefficients(3.4 / 7.0)  # t = alpha / beta
    assert w_mid == pytest.approx(0.65)
    assert c1_0 > c2_0 and c1_1 < c2_1  # large c1 early, large c2 late
    taus = np.linspace(0.0, 1.0, 11)
    rows = np.array([improved_coefficients(t) for t in taus])
    assert np.all(np.diff(rows[:, 0]) < 0) and np.all(np.diff(rows[:, 1]) < 0)
    assert np.all(np.diff(rows[:, 2]) > 0)
    assert np.allclose(rows[:, 1] + rows[:, 2], 1.5)
    assert np.all((rows[:, 1:] >= 0.5) & (rows[:, 1:] <= 1.0))


def test_improved_foa_crossover_probability() -> None:
    smell = np.array([0.0, 1.0, 2.0, 3.0, 4.0, np.inf])  # finite mean 2, best 0
    q = crossover_probability(np.array([0.0, 1.0, 2.0, 3.0, np.inf]), smell, 0.6, 0.9, 9.903438)
    assert q[0] == pytest.approx(0.6, abs=1e-6)  # best pair: q1
    assert q[2] == pytest.approx(0.75)  # average pair: (q1 + q2) / 2
    assert 0.6 < q[1] < 0.75  # better pairs cross less
    assert q[3] == q[4] == 0.9  # worse than average (or failed): q2
    none_ok = crossover_probability(np.array([np.inf]), np.array([np.inf, np.inf]), 0.6, 0.9, 1.0)
    assert none_ok[0] == 0.9


def test_improved_foa_step_shrinks() -> None:
    rng = np.random.default_rng(0)
    early = dynamic_step(rng, 20000, 0.0, 0.01, 0.5)
    late = dynamic_step(rng, 20000, 1.0, 0.01, 0.5)
    assert early.mean() == pytest.approx(2.0, rel=0.03)  # exponential with rate 0.5, c = 0
    assert late.mean() / early.mean() == pytest.approx(0.01 ** (2.0 - math.cos(1.0)), rel=0.05)


def test_abc_rank_fitness() -> None:
    # 1 / (1 + rank), rank = number of strictly better sources; failed sources get 0
    f = np.array([0.0, 1.0, -2.0, np.inf, 1.0])
    assert rank_fitness(f).tolist() == [1 / 2, 1 / 3, 1.0, 0.0, 1 / 3]
    assert rank_fitness(np.full(3, np.inf)).tolist() == [0.0, 0.0, 0.0]


# ---------------------------------------------------------------------------------------------
# Units: every optimiser takes the same path on f and on 1e-9 * f


def contour_like(scale: float) -> Callable[[np.ndarray], np.ndarray]:
    """A multimodal 3-D objective whose values are of order ``scale`` (1e-5: errors in metres)."""
    centre = np.array([0.3, -0.2, 0.1])

    def fn(x: np.ndarray) -> np.ndarray:
        bowl = np.sum((x - centre) ** 2, axis=1)
        return scale * (bowl + 0.1 * np.sum(np.sin(5.0 * x) ** 2, axis=1))

    return fn


# improved_foa's eq. 5 is a ratio of smell differences, scale-free but computed from rounded
# smells, and the same number is eq. 6's crossover weight: offspring may differ by an ulp
ROUNDED = {"improved_foa"}
UNIT_CASES = [pytest.param(name, {}, id=name) for name in NAMES] + [
    pytest.param("cma", {"boundary": "BoundPenalty"}, id="cma-BoundPenalty")
]


def _same_path(name: str, ref: OptimResult, other: OptimResult, factor: float) -> None:
    assert other.nfev == ref.nfev
    assert ref.population_history is not None and other.population_history is not None
    if name in ROUNDED:
        assert np.allclose(other.x, ref.x, rtol=1e-12, atol=1e-14)
        assert np.allclose(other.population_history, ref.population_history, rtol=1e-12, atol=1e-14)
        assert np.allclose(other.history, factor * ref.history, rtol=1e-12, atol=0.0)
    else:
        assert other.x.tobytes() == ref.x.tobytes()
        assert other.population_history.tobytes() == ref.population_history.tobytes()
        assert np.array_equal(other.history, factor * ref.history)


@pytest.mark.parametrize("scale", [1e-5, 1e3])
@pytest.mark.parametrize(("name", "options"), UNIT_CASES)
def test_same_path_on_a_scaled_objective(name: str, options: dict[str, Any], scale: float) -> None:
    fn, bounds = contour_like(scale), [[-1.0, 1.0]] * 3
    kw: dict[str, Any] = {"population": 12, "iterations": 25, "seed": 7, "keep_population": True}
    ref = minimize(name, fn, bounds, **kw, **options)
    scaled = minimize(name, lambda x: 1e-9 * fn(x), bounds, **kw, **options)
    _same_path(name, ref, scaled, 1e-9)


@pytest.mark.parametrize("name", [n for n in NAMES if n != "improved_foa"])
def test_same_path_with_an_offset(name: str) -> None:
    # improved_foa is left out: its trapped test var <= delta * mean^2 is not offset-free
    fn, bounds = contour_like(1e-5), [[-1.0, 1.0]] * 3
    kw: dict[str, Any] = {"population": 12, "iterations": 25, "seed": 7, "keep_population": True}
    ref = minimize(name, fn, bounds, **kw)
    shifted = minimize(name, lambda x: fn(x) + 3e-5, bounds, **kw)
    assert shifted.x.tobytes() == ref.x.tobytes()
    assert ref.population_history is not None and shifted.population_history is not None
    assert shifted.population_history.tobytes() == ref.population_history.tobytes()


# std of five copies of FLAT rounds to 4e-16, of five copies of 1e-9 * FLAT to exactly 0: with
# scipy's convergence test on, DE ran the flat objective's budget at one scale and not the other
FLAT = 3.2155563455066574


@pytest.mark.parametrize("scale", [1.0, 1e-9])
@pytest.mark.parametrize("name", NAMES)
def test_flat_objective_spends_the_budget(name: str, scale: float) -> None:
    assert np.std(np.full(5, FLAT)) > 0.0 and np.std(np.full(5, 1e-9 * FLAT)) == 0.0
    bounds = [[0.0, 1.0]] * 2
    checked = Checked(lambda x: np.full(x.shape[0], scale * FLAT), bounds)
    res = minimize(name, checked, bounds, population=5, iterations=10, seed=0)
    assert checked.evals == res.nfev == 5 * 11
    assert res.fun == scale * FLAT and res.history.shape == (10,)


def test_abc_onlookers_prefer_better_sources_in_si_units() -> None:
    f = 1e-5 * np.array([0.3, 0.8, 1.0, 2.0, 4.0, 7.5])  # contour errors in metres
    karaboga = 1.0 / (1.0 + f)  # the printed fitness: the same for every source to 4 digits
    assert karaboga.max() / karaboga.min() < 1.0 + 1e-4
    for probabilities in (abc_probabilities, iabc_probabilities):
        p = probabilities(f)
        assert p.sum() == pytest.approx(1.0, abs=1e-15)
        assert np.all(np.diff(p) < 0.0)  # a better source is strictly more likely
        assert p[0] > 2.0 * p[-1]
        for other in (1e-9 * f, 1e8 * f, f + 1.0):
            assert np.array_equal(probabilities(other), p)
    # the best gets 1 / H_6 of Karaboga's roulette; eq. 25 gives the worst 0.9 / 6 + 0.1
    assert abc_probabilities(f)[0] == pytest.approx(1.0 / sum(1.0 / k for k in range(1, 7)))
    q = iabc_probabilities(f)
    assert q[0] / q[-1] == pytest.approx(1.0 / (0.9 / 6.0 + 0.1))


def test_abc_onlooker_probabilities_with_failed_sources() -> None:
    f = np.array([2.0, np.inf, 1.0, np.inf, 2.0])
    p = abc_probabilities(f)
    assert p[1] == p[3] == 0.0 and p[2] > p[0] == p[4] > 0.0  # ties share a probability
    q = iabc_probabilities(f)
    assert 0.0 < q[1] == q[3] < q[0] == q[4] < q[2]  # eq. 25's floor, never preferred
    for probabilities in (abc_probabilities, iabc_probabilities):
        assert probabilities(f).sum() == pytest.approx(1.0, abs=1e-15)
        uniform = probabilities(np.full(4, np.inf))  # every source failed
        assert np.all(np.isfinite(uniform)) and np.all(uniform == 0.25)
