"""Compiled fuzzy systems (agents/fuzzy/) against scikit-fuzzy and plain numpy."""

from __future__ import annotations

import numba
import numpy as np
import pytest

from agents import fuzzy as F  # noqa: N812

TOL = 1e-3  # of the output range: the surface's requirement


@pytest.fixture(scope="module")
def pid() -> F.FuzzySystem:
    return F.fuzzy_pid_000()


@pytest.fixture(scope="module")
def feed() -> F.FuzzySystem:
    return F.fuzzy_feedrate_004()


@pytest.fixture(scope="module")
def adaptive() -> F.FuzzySystem:
    return F.adaptive_fuzzy_001()


def points(system: F.FuzzySystem, n: int, seed: int) -> np.ndarray:
    """n random inputs (some beyond the universes) + every pair of set peaks, ends, middles."""
    lo = np.array([v.low for v in system.inputs])
    hi = np.array([v.high for v in system.inputs])
    pad = 0.1 * (hi - lo)
    x = np.random.default_rng(seed).uniform(lo - pad, hi + pad, (n, len(lo)))
    marks = [
        np.unique([s.centre for s in v.sets] + [v.low, v.high, 0.5 * (v.low + v.high)])
        for v in system.inputs
    ]
    grid = np.stack(np.meshgrid(*marks, indexing="ij"), axis=-1).reshape(-1, len(lo))
    return np.concatenate([x, grid])


def span(system: F.FuzzySystem) -> np.ndarray:
    return np.array([v.high - v.low for v in system.outputs])


def tri(name: str, a: float, b: float, c: float) -> F.FuzzySet:
    return F.FuzzySet(name, "trimf", (a, b, c))


def three_triangles(low: float, high: float) -> tuple[F.FuzzySet, ...]:
    mid = 0.5 * (low + high)
    return (tri("N", low, low, mid), tri("Z", low, mid, high), tri("P", mid, high, high))


# --- Mamdani against skfuzzy's ControlSystemSimulation -----------------------------------


def test_pid_000_matches_skfuzzy(pid: F.FuzzySystem) -> None:
    x = points(pid, 240, 1)
    ref = F.reference_evaluate(pid, x, vectorised=True)
    assert np.all(np.isfinite(ref))
    exact = F.evaluate(pid, x, method="exact")
    surface = F.evaluate(pid, x)
    assert np.max(np.abs(exact - ref) / span(pid)) < 1e-12
    assert np.max(np.abs(surface - ref) / span(pid)) <= TOL


def test_vectorised_reference_is_row_mode(pid: F.FuzzySystem) -> None:
    x = points(pid, 5, 2)[:5]
    row = F.reference_evaluate(pid, x)
    np.testing.assert_allclose(F.reference_evaluate(pid, x, vectorised=True), row, atol=1e-13)


def test_feedrate_004_matches_skfuzzy(feed: F.FuzzySystem) -> None:
    x = points(feed, 200, 3)
    ref = F.reference_evaluate(feed, x)
    assert np.all(np.isfinite(ref))  # bell sets: every rule fires, never an empty aggregate
    exact = F.evaluate(feed, x, method="exact")
    assert np.max(np.abs(exact - ref) / span(feed)) < 1e-12
    assert np.max(np.abs(F.evaluate(feed, x) - ref) / span(feed)) <= TOL


def test_surface_follows_exact_densely(pid: F.FuzzySystem, feed: F.FuzzySystem) -> None:
    for system in (pid, feed):
        x = points(system, 20_000, 4)
        diff = F.evaluate(system, x) - F.evaluate(system, x, method="exact")
        assert np.max(np.abs(diff) / span(system)) <= TOL / 2


def test_pid_000_tables_are_oriented_rows_e_columns_de(pid: F.FuzzySystem) -> None:
    # at a pair of peaks exactly one rule fires fully: the output is its set's centroid
    end = 3.0 - 1.0 / 3.0  # centroid of the half triangles NB / PB on [-3, 3]
    cases = [  # (e, de) -> (dKp, dKi, dKd), from the tables as published by Liu
        ((-3, -3), (end, -end, 1.0)),  # NB, NB: PB NB PS
        ((-2, 3), (-1.0, 0.0, 0.0)),  # NM, PB: NS ZO ZO
        ((1, 3), (-2.0, end, 0.0)),  # PS, PB: NM PB ZO
        ((2, -1), (-1.0, 1.0, 1.0)),  # PM, NS: NS PS PS
        ((3, 3), (-end, end, end)),  # PB, PB: NB PB PB
        ((0, 0), (0.0, 0.0, -1.0)),  # ZO, ZO: ZO ZO NS
    ]
    x = np.array([c[0] for c in cases], dtype=float)
    want = np.array([c[1] for c in cases])
    np.testing.assert_allclose(F.evaluate(pid, x, method="exact"), want, atol=1e-9)
    np.testing.assert_allclose(F.evaluate(pid, x), want, atol=1e-9)


def test_feedrate_004_speeds_up_near_zero_and_slows_at_the_tolerance(feed: F.FuzzySystem) -> None:
    y = F.evaluate(feed, np.array([[0.0, 0.0], [1.0, 0.0], [-1.0, 0.0], [0.0, 0.5]]))[:, 0]
    assert y[0] > 0.3 and y[3] > 0.3
    assert y[1] < -0.3 and y[2] < -0.3


def test_inputs_are_clipped_to_the_universes(pid: F.FuzzySystem) -> None:
    x = np.array([[-7.0, 0.4], [3.5, 9.0], [0.2, -3.01]])
    for method in ("surface", "exact"):
        np.testing.assert_allclose(
            F.evaluate(pid, x, method=method),
            F.evaluate(pid, np.clip(x, -3.0, 3.0), method=method),
            atol=1e-12,
        )


def test_empty_aggregate_gives_the_middle_of_the_output_universe() -> None:
    sets = three_triangles(-1.0, 1.0)
    out = F.Variable("y", 0.0, 2.0, three_triangles(0.0, 2.0), n_points=201)
    system = F.FuzzySystem(
        "sparse",
        F.MAMDANI,
        (F.Variable("a", -1.0, 1.0, sets, 201), F.Variable("b", -1.0, 1.0, sets, 201)),
        (out,),
        (F.Rule(("N", "N"), ("P",)),),
    )
    x = np.array([[1.0, 1.0], [0.5, 0.9], [-1.0, -1.0], [-0.7, -0.2]])
    ref = F.reference_evaluate(system, x)
    assert np.isnan(ref[:2]).all() and np.isfinite(ref[2:]).all()  # skfuzzy: no output
    for method in ("exact", "surface"):
        y = F.evaluate(system, x, method=method)
        np.testing.assert_array_equal(y[:2, 0], [1.0, 1.0])
        np.testing.assert_allclose(y[2:], ref[2:], atol=1e-12 if method == "exact" else 2e-3)
    with pytest.raises(ValueError, match="every set of output 'y'"):
        F.reference_evaluate(system, x, vectorised=True)


def _small_system(points: int) -> F.FuzzySystem:
    sets = three_triangles(-1.0, 1.0)
    out = F.Variable("y", 0.0, 2.0, three_triangles(0.0, 2.0), n_points=101)
    rules = tuple(F.Rule((a, b), (b,)) for a in ("N", "Z", "P") for b in ("N", "Z", "P"))
    inputs = (F.Variable("a", -1.0, 1.0, sets, 101), F.Variable("b", -1.0, 1.0, sets, 101))
    return F.FuzzySystem("stored", F.MAMDANI, inputs, (out,), rules, surface_points=points)


def test_a_stored_surface_is_the_tabulated_one_bit_for_bit(tmp_path, monkeypatch) -> None:
    from agents.fuzzy import compiled as C

    tabulated = []

    def tabulate(system: F.FuzzySystem):  # type: ignore[no-untyped-def]
        sampled = C.SampledVariables.of
        base = C.CompiledMamdani(system, sampled(system.inputs), sampled(system.outputs),
                                 system.antecedent_indices(), system.consequent_indices())
        return C.stored_surface(base, lambda: tabulated.append(1) or base._surface())

    monkeypatch.setattr(numba.config, "CACHE_DIR", str(tmp_path))
    first, again = tabulate(_small_system(31)), tabulate(_small_system(31))
    assert tabulated == [1]  # the second read the stored file
    for name in C.SURFACE_FIELDS:
        stored, fresh = getattr(again, name), getattr(first, name)
        assert stored.dtype == fresh.dtype and np.array_equal(stored, fresh), name
    tabulate(_small_system(33))  # another node count: another file
    files = sorted((tmp_path / "fuzzy_surfaces").iterdir())
    assert len(tabulated) == 2 and len(files) == 2
    for file in files:
        file.write_bytes(b"not an npz")  # unreadable: tabulated again, and stored
    tabulate(_small_system(31))
    assert len(tabulated) == 3 and tabulate(_small_system(31)) and len(tabulated) == 3
    kept = max(files, key=lambda f: f.stat().st_size)  # the 31 nodes' file, stored again
    kept.write_bytes(kept.read_bytes()[: kept.stat().st_size // 2])  # cut off: tabulated
    tabulate(_small_system(31))
    assert len(tabulated) == 4
    monkeypatch.setattr(numba.config, "CACHE_DIR", "")  # no cache folder: tabulated
    tabulate(_small_system(31))
    assert len(tabulated) == 5


def test_three_input_mamdani_has_no_surface_and_uses_exact() -> None:
    sets = three_triangles(-1.0, 1.0)
    inputs = tuple(F.Variable(n, -1.0, 1.0, sets, 101) for n in "abc")
    rules = tuple(
        F.Rule((p, q, r), ("P" if (p, q, r).count("P") >= 2 else "N",))
        for p in "NZP"
        for q in "NZP"
        for r in "NZP"
    )
    system = F.FuzzySystem(
        "three", F.MAMDANI, inputs, (F.Variable("y", -1.0, 1.0, sets, 101),), rules
    )
    x = points(system, 30, 5)
    assert system.compiled.surface is None  # type: ignore[union-attr]
    ref = F.reference_evaluate(system, x)
    np.testing.assert_allclose(F.evaluate(system, x), ref, atol=1e-12)
    with pytest.raises(ValueError, match="no surface"):
        F.evaluate(system, x, method="surface")


# --- product inference / centre average --------------------------------------------------


@pytest.mark.parametrize("n_sets", [3, 5, 7])
def test_basis_matches_numpy_reference(n_sets: int) -> None:
    system = F.adaptive_fuzzy_001(n_sets)
    x = points(system, 500, 6)
    xi = F.basis(system, x)
    assert xi.shape == (len(x), n_sets**2)
    np.testing.assert_allclose(xi.sum(axis=1), 1.0, atol=1e-12)
    np.testing.assert_allclose(xi, F.reference_basis(system, x), atol=1e-12, rtol=0)


def test_output_is_theta_dot_basis(adaptive: F.FuzzySystem) -> None:
    x = points(adaptive, 300, 7)
    theta0 = F.initial_theta(adaptive)
    assert theta0.shape == (3, 25) and not theta0.any()
    np.testing.assert_array_equal(F.evaluate(adaptive, x), 0.0)  # starts at the base gains
    theta = np.random.default_rng(8).normal(size=theta0.shape)
    y = F.evaluate(adaptive, x, theta=theta)
    np.testing.assert_allclose(y, F.reference_basis(adaptive, x) @ theta.T, atol=1e-12)


def test_triangular_product_system_and_no_firing() -> None:
    sets = three_triangles(-1.0, 1.0)
    centres = F.Variable("y", -1.0, 1.0, three_triangles(-1.0, 1.0), 101)
    rules = (F.Rule(("N", "N"), ("P",)), F.Rule(("Z", "P"), ("N",)), F.Rule(("P", "Z"), ("Z",)))
    system = F.FuzzySystem(
        "tri",
        F.PRODUCT,
        (F.Variable("a", -1.0, 1.0, sets, 101), F.Variable("b", -1.0, 1.0, sets, 101)),
        (centres,),
        rules,
    )
    np.testing.assert_array_equal(F.initial_theta(system), [[1.0, -1.0, 0.0]])
    x = np.array([[-1.0, -1.0], [-0.5, -0.8], [0.3, 0.6], [1.0, 1.0], [-1.0, 1.0]])
    xi = F.basis(system, x)
    np.testing.assert_allclose(xi, F.reference_basis(system, x), atol=1e-12)
    np.testing.assert_array_equal(xi[3:], 0.0)  # nothing fires at (1, 1), (-1, 1)
    np.testing.assert_array_equal(F.evaluate(system, x)[3:], 0.0)
    np.testing.assert_allclose(F.evaluate(system, x)[0], [1.0])


# --- batch vs single, bit for bit ---------------------------------------------------------


def test_batch_equals_one_at_a_time(
    pid: F.FuzzySystem, feed: F.FuzzySystem, adaptive: F.FuzzySystem
) -> None:
    theta = np.random.default_rng(9).normal(size=(3, 25))
    cases = [
        (pid, {"method": "surface"}),
        (pid, {"method": "exact"}),
        (feed, {"method": "surface"}),
        (feed, {"method": "exact"}),
        (adaptive, {"theta": theta}),
    ]
    for system, kwargs in cases:
        x = points(system, 64, 10)
        batch = F.evaluate(system, x, **kwargs)
        single = np.concatenate([F.evaluate(system, x[i : i + 1], **kwargs) for i in range(len(x))])
        np.testing.assert_array_equal(batch, single)
    x = points(adaptive, 64, 11)
    single_xi = np.concatenate([F.basis(adaptive, x[i : i + 1]) for i in range(len(x))])
    np.testing.assert_array_equal(F.basis(adaptive, x), single_xi)


# --- the kernels called from other compiled code -------------------------------------------


@numba.njit
def _tick_surface(tables, flips, grid, empty, x, out, last):  # type: ignore[no-untyped-def]
    gains = np.empty(tables.shape[0])
    for b in range(x.shape[0]):
        F.surface_eval_into(tables, flips, grid, empty, x[b, 0], x[b, 1], gains)
        out[b] = gains
        last[b] = F.surface_eval(tables, flips, grid, empty, tables.shape[0] - 1, x[b, 0], x[b, 1])


@numba.njit
def _tick_product(mf, meta, ant, theta, x, out):  # type: ignore[no-untyped-def]
    mu = np.zeros((mf.shape[0], mf.shape[1]))
    xi = np.zeros(ant.shape[0])
    for b in range(x.shape[0]):
        F.product_basis_into(mf, meta, ant, x[b], mu, xi)
        F.product_output_into(theta, xi, out[b])


@numba.njit
def _tick_exact(  # type: ignore[no-untyped-def]
    in_mf, in_meta, ant, cons, out_mf, out_meta, out_sup, x, mu, cut, agg, buf, out
):
    raw = np.empty((0, 2))
    for b in range(x.shape[0]):
        F.mamdani_exact_into(
            in_mf,
            in_meta,
            ant,
            cons,
            out_mf,
            out_meta,
            out_sup,
            x[b],
            mu,
            cut,
            agg,
            buf,
            out[b],
            raw,
        )


def test_kernels_are_callable_from_other_compiled_code(
    pid: F.FuzzySystem, adaptive: F.FuzzySystem
) -> None:
    x = points(pid, 50, 12)
    compiled = pid.compiled
    assert isinstance(compiled, F.CompiledMamdani) and compiled.surface is not None
    sf = compiled.surface
    out, last = np.empty((len(x), 3)), np.empty(len(x))
    _tick_surface(sf.tables, sf.flips, sf.grid, sf.empty, x, out, last)
    np.testing.assert_array_equal(out, F.evaluate(pid, x))
    np.testing.assert_array_equal(last, out[:, 2])
    _tick_surface(sf.tables, sf.flips, sf.grid, sf.empty, np.array([[np.nan, 0.0]]), out, last)
    assert np.isnan(out[0]).all() and np.isnan(last[0])
    exact = np.empty((len(x), 3))
    i, o = compiled.inputs, compiled.outputs
    _tick_exact(
        i.mf,
        i.meta,
        compiled.ant,
        compiled.cons,
        o.mf,
        o.meta,
        o.support,
        x,
        *compiled.workspace(),
        exact,
    )
    np.testing.assert_array_equal(exact, F.evaluate(pid, x, method="exact"))
    _tick_exact(
        i.mf,
        i.meta,
        compiled.ant,
        compiled.cons,
        o.mf,
        o.meta,
        o.support,
        np.array([[0.0, np.nan]]),
        *compiled.workspace(),
        exact,
    )
    assert np.isnan(exact[0]).all()
    cp = adaptive.compiled
    assert isinstance(cp, F.CompiledProduct)
    theta = np.random.default_rng(13).normal(size=cp.theta0.shape)
    y = np.empty((len(x), 3))
    _tick_product(cp.inputs.mf, cp.inputs.meta, cp.ant, theta, x, y)
    np.testing.assert_array_equal(y, F.evaluate(adaptive, x, theta=theta))
    _tick_product(cp.inputs.mf, cp.inputs.meta, cp.ant, theta, np.array([[np.nan, 0.0]]), y)
    assert np.isnan(y[0]).all()


# --- bad input and bad definitions ---------------------------------------------------------


def test_bad_inputs_raise_naming_them(pid: F.FuzzySystem, adaptive: F.FuzzySystem) -> None:
    with pytest.raises(ValueError, match="inputs must be finite"):
        F.evaluate(pid, [[0.0, np.nan]])
    with pytest.raises(ValueError, match="inputs must have shape"):
        F.evaluate(pid, np.zeros((4, 3)))
    with pytest.raises(ValueError, match="inputs must have 2 dimension"):
        F.evaluate(pid, np.zeros(2))
    with pytest.raises(ValueError, match="inputs must be finite"):
        F.basis(adaptive, [[np.inf, 0.0]])
    with pytest.raises(ValueError, match="theta must have shape"):
        F.evaluate(adaptive, np.zeros((1, 2)), theta=np.zeros((3, 24)))
    with pytest.raises(ValueError, match="theta must be finite"):
        F.evaluate(adaptive, np.zeros((1, 2)), theta=np.full((3, 25), np.nan))
    with pytest.raises(ValueError, match="method"):
        F.evaluate(pid, np.zeros((1, 2)), method="bilinear")
    with pytest.raises(ValueError, match="mamdani systems only"):
        F.evaluate(adaptive, np.zeros((1, 2)), method="exact")
    with pytest.raises(ValueError, match="theta applies"):
        F.evaluate(pid, np.zeros((1, 2)), theta=np.zeros((3, 49)))
    with pytest.raises(ValueError, match="needs a product_centre_average"):
        F.basis(pid, np.zeros((1, 2)))
    with pytest.raises(ValueError, match="needs a mamdani"):
        F.control_system(adaptive)


def test_bad_definitions_raise() -> None:
    sets = three_triangles(-1.0, 1.0)
    a, b = F.Variable("a", -1.0, 1.0, sets, 21), F.Variable("b", -1.0, 1.0, sets, 21)
    y = F.Variable("y", -1.0, 1.0, sets, 21)

    def system(rules: tuple[F.Rule, ...], kind: str = F.MAMDANI) -> F.FuzzySystem:
        return F.FuzzySystem("bad", kind, (a, b), (y,), rules)

    with pytest.raises(ValueError, match="rule 1: variable 'b' has no set 'XX'"):
        system((F.Rule(("N", "N"), ("P",)), F.Rule(("N", "XX"), ("P",))))
    with pytest.raises(ValueError, match="variable 'y' has no set 'PB'"):
        system((F.Rule(("N", "N"), ("PB",)),))
    with pytest.raises(ValueError, match="rule 0: 'when' names 1 sets"):
        system((F.Rule(("N",), ("P",)),))
    with pytest.raises(ValueError, match="unknown fuzzy system kind"):
        system((F.Rule(("N", "N"), ("P",)),), kind="sugeno")
    with pytest.raises(ValueError, match="needs inputs, outputs and rules"):
        system(())
    with pytest.raises(ValueError, match="low must be < high"):
        F.Variable("u", 1.0, 1.0, sets)
    with pytest.raises(ValueError, match="low must be < high"):
        F.Variable("u", 2.0, -2.0, sets)
    with pytest.raises(ValueError, match="duplicate set names"):
        F.Variable("u", -1.0, 1.0, (sets[0], sets[0]))
    with pytest.raises(ValueError, match="is 0 on the universe"):
        F.Variable("u", -1.0, 1.0, (tri("far", 5.0, 6.0, 7.0),))
    with pytest.raises(ValueError, match="duplicate variable names"):
        F.FuzzySystem("bad", F.MAMDANI, (a, a), (y,), (F.Rule(("N", "N"), ("P",)),))
    with pytest.raises(ValueError, match="non-decreasing"):
        tri("x", 1.0, 0.0, 2.0)
    with pytest.raises(ValueError, match="sigma must be > 0"):
        F.FuzzySet("g", "gaussmf", (0.0, 0.0))
    with pytest.raises(ValueError, match="membership kind"):
        F.FuzzySet("g", "sigmf", (0.0, 1.0))
    with pytest.raises(ValueError, match="needs 3 finite parameters"):
        F.FuzzySet("t", "trimf", (0.0, 1.0))
    with pytest.raises(ValueError, match="n_sets must be 3, 5 or 7"):
        F.adaptive_fuzzy_001(4)
