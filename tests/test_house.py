"""The house: extension by registration from outside the package, one import direction, the
compiled-code cache keyed by kernel code only, swappable rewards, vector info (issue 10)."""

import ast
import pathlib

import gymnasium as gym
import numba
import numpy as np
import pytest
from gymnasium.utils.env_checker import data_equivalence
from gymnasium.vector import VectorEnv

import contour_gym
from contour_gym import jit
from contour_gym._schema import Param, Schema
from contour_gym._validate import finite, positive
from contour_gym.api import make_scenario, simulate
from contour_gym.ccc import CCCGains
from contour_gym.contour import ContourEstimator, estimate_full, register_estimator
from contour_gym.contour._estimators import far_off, line_foot
from contour_gym.contour.base import ESTIMATORS
from contour_gym.paths._geom import eval_path
from contour_gym.plant import AxisParams, Contour, Stage
from contour_gym.presets import PRESETS, Preset, get_preset, register_preset
from contour_gym.rewards import COMPONENTS, RC, REWARDS, CompiledReward, register_reward
from contour_gym.servo import PIDGains

PACKAGE = pathlib.Path(contour_gym.__file__).parent

# ------------------------------------------------------------------ a toy estimator, here

TOY = Schema("toy_tangent", bias=Param(0.0, finite, "offset to the left of travel, m"))
_C = TOY.col


@numba.njit(cache=True, inline="always")
def toy_foot(p, kind, s0, data, bound, p0, p1, p2, s, hist):
    """The foot on the tangent line at the reference, moved ``bias`` to the left (2-D)."""
    rx, ry, rz, tx, ty, tz, kx, ky, kz = eval_path(kind, s0, data, s)
    if far_off(p0, p1, p2, rx, ry, rz, tx, ty, tz, kx, ky, kz, 1.0):
        return False, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    qx, qy, qz = line_foot(p0, p1, p2, rx, ry, rz, tx, ty, tz)
    norm = (tx * tx + ty * ty) ** 0.5
    b = p[_C.bias]
    return True, qx - b * ty / norm, qy + b * tx / norm, qz, tx, ty, tz, -1.0


@pytest.fixture
def toy_estimator():
    est = register_estimator(ContourEstimator("toy_tangent", TOY, toy_foot, doc="a test's toy"))
    yield est
    ESTIMATORS.unregister("toy_tangent")


def test_a_toy_estimator_registered_from_a_test_module_runs_in_the_loop(toy_estimator):
    sc = make_scenario("xy_dc_servo", ideal=True)
    loop = sc.loop(estimator="toy_tangent", estimator_options={"bias": 2e-6}, record=True,
                   ccc_gains=sc.preset.ccc_gains.as_tuple())
    loop.reset(0)
    loop.step(800)
    tr = loop.trace()
    python = estimate_full("toy_tangent", sc.path, tr.s[0], tr.x[0], bias=2e-6)
    np.testing.assert_allclose(python.eps, tr.eps_est[0, :, 0], rtol=0, atol=1e-15)
    plain = estimate_full("tangent", sc.path, tr.s[0], tr.x[0])
    # its option acts: the foot 2 um to the left puts the tool 2 um further right (eps < 0)
    np.testing.assert_allclose(python.eps - plain.eps, -2e-6, rtol=1e-6)
    with pytest.raises(ValueError, match="toy_tangent.bias"):
        sc.loop(estimator="toy_tangent", estimator_options={"bias": float("nan")})


# --------------------------------------------------------------------- a toy machine, here


def toy_mill() -> Preset:
    axes = tuple(AxisParams(n, mass=5.0, damping=20.0, force_constant=40.0, u_max=8.0,
                            encoder_resolution=1e-6) for n in ("x", "y"))
    stage = Stage("toy_mill", axes, (Contour((0, 1)),), ts=1e-3, in_position=1e-5,
                  notes="a test's toy: every number chosen")
    gains = tuple(PIDGains(kp=2000.0, ki=2e4, kd=15.0) for _ in axes)
    return Preset("toy_mill", "user", stage, gains, CCCGains(2000.0, 2e4), path="circle_r20",
                  feedrate=0.02, accel=1.0, max_feedrate=0.1)


@pytest.fixture
def registered_mill():
    register_preset("toy_mill", toy_mill)
    yield
    PRESETS.unregister("toy_mill")


def test_a_toy_preset_registered_from_a_test_module_is_usable_everywhere(registered_mill):
    m = simulate(plant="toy_mill")
    assert m["finished"] == 1.0 and 0 < m["max_contour_error"] < 1e-3
    env = gym.make("contour_gym/CCC-v0", plant="toy_mill")
    env.reset(seed=0)
    _, r, *_ = env.step(env.unwrapped.gains_to_action(env.unwrapped.task.g0))
    assert np.isfinite(r)


def test_plant_dict_overrides_a_presets_fields():
    base = get_preset("xy_dc_servo")
    mass = 3 * base.stage.axes[0].mass
    heavy = {"preset": "xy_dc_servo", "stage": {"axes": {"x": {"mass": mass}}}}
    a = simulate(plant="xy_dc_servo", ideal=True)
    b = simulate(plant=heavy, ideal=True)
    assert b["max_contour_error"] > a["max_contour_error"]
    with pytest.raises(ValueError, match="masss"):
        simulate(plant={"preset": "xy_dc_servo", "stage": {"axes": {"x": {"masss": 1.0}}}})
    with pytest.raises(ValueError, match="no item 'z'"):
        simulate(plant={"preset": "xy_dc_servo", "stage": {"axes": {"z": {"mass": 1.0}}}})


# -------------------------------------------------------------------- one import direction


def _module_imports(path: pathlib.Path) -> set[str]:
    """Modules a file imports at module level (not under ``if TYPE_CHECKING``)."""
    tree = ast.parse(path.read_text())
    out = set()
    for node in tree.body:
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            out.add(node.module)
            out.update(f"{node.module}.{a.name}" for a in node.names)
        elif isinstance(node, ast.Import):
            out.update(a.name for a in node.names)
    return {m for m in out if m.startswith("contour_gym.")}


def _layer(module: str) -> str:
    parts = module.split(".")
    return ".".join(parts[:2])


def _assert_acyclic(graph: dict[str, set[str]]) -> None:
    """A depth-first search for a cycle; the error shows it."""
    state: dict[str, int] = {}

    def visit(node: str, trail: list[str]) -> None:
        state[node] = 1
        for nxt in sorted(graph.get(node, ())):
            if state.get(nxt) == 1:
                raise AssertionError(" -> ".join([*trail, node, nxt]))
            if nxt not in state:
                visit(nxt, [*trail, node])
        state[node] = 2

    for node in sorted(graph):
        if node not in state:
            visit(node, [])


def test_the_packages_import_in_one_direction_only():
    graph: dict[str, set[str]] = {}
    for path in PACKAGE.rglob("*.py"):
        rel = path.relative_to(PACKAGE.parent).with_suffix("").as_posix().replace("/", ".")
        if rel == "contour_gym.__init__":
            continue  # the package root imports everything to register the ids
        src = _layer(rel.removesuffix(".__init__"))
        for dst in map(_layer, _module_imports(path)):
            if dst != src and dst != "contour_gym":
                graph.setdefault(src, set()).add(dst)
    _assert_acyclic(graph)
    assert "contour_gym.presets" not in graph.get("contour_gym.plant", set())
    assert "contour_gym.servo" not in graph.get("contour_gym.plant", set())


# ------------------------------------------------------------- the compiled-code cache key


def test_the_cache_key_ignores_docstrings_and_comments_and_non_kernel_modules():
    code = 'def f(x):\n    """Doc."""\n    return x + 1  # why\n'
    assert jit.code_digest(code) == jit.code_digest(
        'def f(x):\n    """Another doc."""\n    # a comment\n    return x + 1\n')
    assert jit.code_digest(code) != jit.code_digest("def f(x):\n    return x + 2\n")
    kernels = {p.relative_to(PACKAGE).as_posix() for p in jit.kernel_sources()}
    assert "loop/kernel.py" in kernels and "plant/friction/lugre.py" in kernels
    assert "api.py" not in kernels and "envs/ccc.py" not in kernels


def test_the_package_digest_is_remembered_and_a_bad_memo_is_recomputed(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    first = jit.package_digest()  # parsed, then remembered
    memos = list((tmp_path / "contour_gym" / "digests").iterdir())
    assert len(memos) == 1 and memos[0].read_text() == first == jit.current_digest()
    assert jit.package_digest() == first
    memos[0].unlink()
    memos[0].write_text("not a digest")
    assert jit.package_digest() == first
    assert memos[0].read_text() == first  # written afresh
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "a file" / "below"))
    (tmp_path / "a file").write_text("")  # no memo can be written: computed all the same
    assert jit.package_digest() == first


def test_a_function_of_a_generated_kernel_is_named_by_its_module_whose_name_is_a_digest():
    # the module's name digests its text, whose header names its slots' identities
    def run_members():
        return 0

    run_members.__module__ = f"{jit.GENERATED_PACKAGE}.k_0123456789abcdef0123"
    assert jit.identity(run_members) == f"{run_members.__module__}.{run_members.__qualname__}"


# -------------------------------------------------------------------- swappable rewards


def test_a_python_reward_and_a_registered_compiled_reward_replace_the_default():
    def progress_only(components):
        return components["progress"] - components["contour"]

    env = gym.make("contour_gym/CCC-Circle-v0", reward=progress_only).unwrapped
    env.reset(seed=0)
    _, r, _, _, info = env.step(np.zeros(3))
    comp = info["reward_components"]
    assert set(comp) == set(COMPONENTS.names)
    assert r == pytest.approx(comp["progress"] - comp["contour"], rel=1e-12)

    weights = Schema("peak reward", peak=Param(2.0, positive))
    w = weights.col

    @numba.njit(cache=True, inline="always")
    def peak_reward(c, wt):
        return -wt[w.peak] * c[RC.peak]

    register_reward(CompiledReward("test_peak", weights, peak_reward))
    try:
        env = gym.make("contour_gym/CCC-Circle-v0", reward="test_peak",
                       reward_weights={"peak": 3.0}).unwrapped
        env.reset(seed=0)
        _, r, _, _, info = env.step(np.zeros(3))
        assert r == pytest.approx(-3.0 * info["reward_components"]["peak"], rel=1e-12)
    finally:
        REWARDS.unregister("test_peak")
    with pytest.raises(ValueError, match="unknown reward"):
        gym.make("contour_gym/CCC-Circle-v0", reward="nope")


def test_the_feedrate_rewards_margin_charges_the_peak_above_it():
    env = gym.make("contour_gym/Feedrate-Corner-v0", feedrate_override=2.0, decision_ticks=20,
                   reward_weights={"excess": 30.0, "margin": 0.5}).unwrapped
    env.reset(seed=0)
    charged = 0
    for _ in range(400):
        _, r, terminated, truncated, info = env.step(np.ones(1))
        c = info["reward_components"]
        expected = c["progress"] - 1.0 - 30.0 * max(0.0, c["peak"] - 0.5)
        assert r == pytest.approx(expected, rel=1e-12, abs=1e-12)
        charged += 0.5 < c["peak"] <= 1.0  # charged below the tolerance
        if terminated or truncated:
            break
    assert charged > 0
    with pytest.raises(ValueError, match="margin"):
        gym.make("contour_gym/Feedrate-Corner-v0", reward_weights={"margin": 0.0})


# ------------------------------------------------------------------------- vector info


class _Merger(VectorEnv):
    """Gymnasium's own merging of single-env infos (``VectorEnv._add_info``)."""

    def __init__(self, n):
        self.num_envs = n


@pytest.mark.parametrize("env_id", ["contour_gym/CCC-Circle-v0", "contour_gym/Feedrate-Corner-v0"])
def test_vector_env_info_equals_the_single_envs_infos(env_id):
    n, steps = 3, 40
    kw = {"decision_ticks": 50, "step_limit": 15}
    venv = gym.make_vec(env_id, num_envs=n, **kw)
    singles = [gym.make(env_id, **kw).unwrapped for _ in range(n)]
    rng = np.random.default_rng(1)
    actions = rng.uniform(-1, 1, (steps, n, venv.single_action_space.shape[0]))
    _, vinfo = venv.reset(seed=5)
    merger, merged = _Merger(n), {}
    for i, env in enumerate(singles):
        merged = merger._add_info(merged, env.reset(seed=5 + i)[1], i)
    assert data_equivalence(vinfo, merged)
    done = np.zeros(n, bool)
    for k in range(steps):
        _, _, te, tr, vinfo = venv.step(actions[k])
        merged = {}
        for i, env in enumerate(singles):
            if done[i]:  # next-step autoreset: the member was reset instead of stepped
                info = env.reset()[1]
                done[i] = False
            else:
                _, _, t1, t2, info = env.step(actions[k, i])
                done[i] = t1 or t2
            merged = merger._add_info(merged, info, i)
        assert data_equivalence(vinfo, merged), k


def _agents_imports(path: pathlib.Path) -> set[str]:
    """Modules of ``agents`` a file imports at module level (``from agents import x``: x)."""
    out = set()
    for node in ast.parse(path.read_text()).body:
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            if node.module == "agents":
                out.update(f"agents.{a.name}" for a in node.names)
            elif node.module.startswith("agents."):
                out.add(node.module)
        elif isinstance(node, ast.Import):
            out.update(a.name for a in node.names if a.name.startswith("agents."))
    return out


def test_agents_modules_import_without_a_circle():
    root = PACKAGE.parent / "agents"
    graph: dict[str, set[str]] = {}
    for path in root.rglob("*.py"):
        mod = ".".join(path.relative_to(root.parent).with_suffix("").parts)
        graph[mod.removesuffix(".__init__")] = {
            m for m in _agents_imports(path) if m != mod.removesuffix(".__init__")
        }
    _assert_acyclic(graph)
    assert "agents.ccc_policies" not in graph["agents.policies"]  # registered on first use


# ------------------------------------------------------------ a house a newcomer can walk

AGENTS = PACKAGE.parent / "agents"


def _private_contour_gym_imports(path: pathlib.Path) -> list[str]:
    """``contour_gym`` names a file imports whose module path or name is private (``_x``)."""
    out = []
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            modules, names = [node.module], [a.name for a in node.names]
        elif isinstance(node, ast.Import):
            modules, names = [a.name for a in node.names], []
        else:
            continue
        for module in modules:
            if module.split(".")[0] != "contour_gym":
                continue
            private = [p for p in module.split(".") if p.startswith("_")]
            out += [f"{module} ({', '.join(names)})"] if private else []
            out += [f"{module}.{n}" for n in names if n.startswith("_")]
    return out


def test_agents_import_only_public_names_of_contour_gym():
    found = {str(p.relative_to(AGENTS.parent)): _private_contour_gym_imports(p)
             for p in sorted(AGENTS.rglob("*.py"))}
    assert {k: v for k, v in found.items() if v} == {}


def test_the_env_core_has_no_branch_on_the_task_kind():
    """The task kinds are strategies (contour_gym.tasks): neither the env core nor its kernel
    compares a task kind."""
    kinds = {"CCC", "FEEDRATE", "KIND_CCC", "KIND_FEEDRATE", "kind"}
    for name in ("envs/core.py", "envs/_kernel.py"):
        for node in ast.walk(ast.parse((PACKAGE / name).read_text())):
            if isinstance(node, ast.Compare):
                names = {n.id for n in ast.walk(node) if isinstance(n, ast.Name)}
                attrs = {n.attr for n in ast.walk(node) if isinstance(n, ast.Attribute)}
                assert not (names | attrs) & kinds, f"{name}:{node.lineno}"


MAX_FILE_LINES, MAX_FUNCTION_LINES = 700, 60


def test_no_file_over_700_lines_and_no_function_over_60():
    big_files, long_functions = [], []
    for path in sorted([*PACKAGE.rglob("*.py"), *AGENTS.rglob("*.py")]):
        text = path.read_text()
        rel = path.relative_to(PACKAGE.parent).as_posix()
        if len(text.splitlines()) > MAX_FILE_LINES:
            big_files.append((rel, len(text.splitlines())))
        for node in ast.walk(ast.parse(text)):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                length = (node.end_lineno or node.lineno) - node.lineno + 1
                if length > MAX_FUNCTION_LINES:
                    long_functions.append((rel, node.name, length))
    assert big_files == [] and long_functions == []


def test_no_formatter_markers_where_no_formatter_runs():
    # CI runs ruff's linter, not a formatter (issue 62): a "fmt: skip" or "fmt: off" marker
    # would claim a layout that nothing keeps
    marker = "# fmt" + ":"
    folders = ("contour_gym", "agents", "tests", "benchmarks", "docs")
    files = sorted(p for d in folders for p in (PACKAGE.parent / d).rglob("*.py"))
    found = [f"{p.relative_to(PACKAGE.parent)}:{i}" for p in files
             for i, line in enumerate(p.read_text().splitlines(), 1) if marker in line]
    assert found == []
