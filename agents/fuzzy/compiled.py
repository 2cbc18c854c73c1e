"""Fuzzy systems compiled to kernel arrays, and their batched evaluation for Python callers.

:func:`compile_system` turns a :class:`~agents.fuzzy.system.FuzzySystem` into the arrays the
kernels of :mod:`agents.fuzzy.kernels` read (:class:`SampledVariables`), with the
:class:`Surface` of a two-input Mamdani system, tabulated at its first use.
:func:`evaluate`, :func:`basis` and :func:`initial_theta` run them on a batch of inputs.
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import zipfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numba
import numpy as np
from numpy.typing import ArrayLike

from agents.fuzzy.kernels import Surface, _mamdani_exact_batch, _product_batch, _surface_batch
from agents.fuzzy.system import (
    PRODUCT,
    Array,
    FuzzySystem,
    IntArray,
    Variable,
    check_inputs,
    register_compiler,
)
from contour_gym.files import write_handle_atomically
from contour_gym.params import as_finite_array, choice


@dataclass(frozen=True, eq=False)
class SampledVariables:
    """Variables as kernel arrays: zero-padded sampled sets and their universes.

    Attributes:
        mf: (n_var, S, N) every set sampled on its variable's universe by
            ``skfuzzy.membership`` (the arrays the skfuzzy reference holds), zero-padded.
        meta: (n_var, 5) universe low, high, step, sample count and set count (columns
            ``M_LOW``, ``M_HIGH``, ``M_STEP``, ``M_POINTS``, ``M_SETS``).
        support: (n_var, S, 2) int64 first and last sample where each set is > 0.
    """

    mf: Array
    meta: Array
    support: IntArray

    @classmethod
    def of(cls, variables: tuple[Variable, ...]) -> SampledVariables:
        """Sample ``variables`` into padded arrays."""
        s_max = max(len(v.sets) for v in variables)
        n_max = max(int(v.n_points) for v in variables)
        mf = np.zeros((len(variables), s_max, n_max))
        support = np.zeros((len(variables), s_max, 2), dtype=np.int64)
        meta = np.zeros((len(variables), 5))
        for k, var in enumerate(variables):
            m = var.memberships()
            mf[k, : m.shape[0], : m.shape[1]] = m
            for s in range(m.shape[0]):
                nz = np.flatnonzero(m[s] > 0.0)
                support[k, s] = nz[0], nz[-1]
            n = int(var.n_points)
            meta[k] = var.low, var.high, (var.high - var.low) / (n - 1), n, len(var.sets)
        return cls(mf, meta, support)


@dataclass(frozen=True, eq=False)
class CompiledMamdani:
    """A Mamdani system as kernel arrays, with its surface when it has two inputs.

    Attributes:
        system: The definition.
        inputs: Sampled input sets.
        outputs: Sampled output sets.
        ant: (R, n_in) antecedent set indices.
        cons: (R, n_out) consequent set indices.
        surface: The surface (two-input systems), else None.
    """

    system: FuzzySystem
    inputs: SampledVariables
    outputs: SampledVariables
    ant: IntArray
    cons: IntArray
    surface: Surface | None = None

    def workspace(self) -> tuple[Array, Array, Array, Array]:
        """Fresh ``mu, cut, agg, buf`` workspaces for :func:`mamdani_exact_into`."""
        i, o = self.inputs.mf.shape, self.outputs.mf.shape
        return np.zeros(i[:2]), np.zeros(o[:2]), np.zeros(o[2]), np.zeros(2 * o[1])

    def exact(self, x: Array, raw: Array | None = None) -> Array:
        """Exact compiled inference on checked inputs.

        Args:
            x: (B, n_in) finite inputs, C-contiguous.
            raw: Optional (B, n_out, 2) array that receives each aggregate's moment and area.

        Returns:
            (B, n_out) outputs.
        """
        out = np.empty((x.shape[0], self.cons.shape[1]))
        raw_ = np.empty((x.shape[0], 0, 2)) if raw is None else raw
        i, o = self.inputs, self.outputs
        _mamdani_exact_batch(
            i.mf, i.meta, self.ant, self.cons, o.mf, o.meta, o.support, x, out, raw_
        )
        return out

    def lookup(self, x: Array) -> Array:
        """Surface lookup on checked (B, 2) C-contiguous inputs."""
        if self.surface is None:
            raise ValueError(f"system {self.system.name!r} has no surface (needs 2 inputs)")
        sf = self.surface
        out = np.empty((x.shape[0], sf.tables.shape[0]))
        _surface_batch(sf.tables, sf.flips, sf.grid, sf.empty, x, out)
        return out

    def with_surface(self) -> CompiledMamdani:
        """A copy with the surface tabulated on ``system.surface_points`` nodes per input.

        The surface is kept in the compiled code's cache folder (:func:`stored_surface`): a
        process after the first reads it instead of tabulating it again.
        """
        surface = stored_surface(self, self._surface)
        return CompiledMamdani(self.system, self.inputs, self.outputs, self.ant, self.cons, surface)

    def _surface(self) -> Surface:
        g = int(self.system.surface_points)
        nodes = [np.linspace(v.low, v.high, g) for v in self.system.inputs]
        at_nodes = self._raw_grid(nodes[0], nodes[1])
        at_mids = self._raw_grid(*(0.5 * (n[1:] + n[:-1]) for n in nodes))
        slash = 0.5 * (at_nodes[..., :-1, :-1] + at_nodes[..., 1:, 1:])
        back = 0.5 * (at_nodes[..., 1:, :-1] + at_nodes[..., :-1, 1:])
        flips = (np.abs(back - at_mids) < np.abs(slash - at_mids)).astype(np.uint8)
        grid = np.array([[v.low, (v.high - v.low) / (g - 1)] for v in self.system.inputs])
        empty = np.array([0.5 * (v.low + v.high) for v in self.system.outputs])
        return Surface(at_nodes, flips, grid.ravel(), empty)

    def _raw_grid(self, n0: Array, n1: Array) -> Array:
        # (n_out, 2, len(n0), len(n1)) moment and area on the grid n0 x n1
        points = np.stack(np.meshgrid(n0, n1, indexing="ij"), axis=-1).reshape(-1, 2)
        raw = np.empty((points.shape[0], self.cons.shape[1], 2))
        self.exact(np.ascontiguousarray(points), raw)
        grid = raw.reshape(len(n0), len(n1), -1, 2).transpose(2, 3, 0, 1)
        return np.ascontiguousarray(grid)


@dataclass(frozen=True, eq=False)
class CompiledProduct:
    """A product / centre-average system as kernel arrays.

    Attributes:
        system: The definition.
        inputs: Sampled input sets.
        ant: (L, n_in) antecedent set indices.
        theta0: (n_out, L) initial consequent centres (the centres of the rules' output sets).
    """

    system: FuzzySystem
    inputs: SampledVariables
    ant: IntArray
    theta0: Array


SURFACE_FIELDS = ("tables", "flips", "grid", "empty")


def stored_surface(compiled: CompiledMamdani, tabulate: Callable[[], Surface]) -> Surface:
    """The surface of ``compiled``: read from the cache folder, else ``tabulate()`` and stored.

    Tabulating 000's fuzzy PID CCC's two surfaces takes 0.5 s, in every process that runs
    the law (each bench or test worker). The file is named by a digest of everything the
    surface is computed from: the kernel arrays, the node count and the source of
    :mod:`agents.fuzzy.kernels` and of this module, so a change to any of them tabulates
    anew. The folder is numba's cache folder
    (``numba.config.CACHE_DIR``: ``NUMBA_CACHE_DIR``, or the one :mod:`contour_gym.jit`
    chooses); without one, or where it cannot be read or written, the surface is tabulated.
    """
    folder = str(getattr(numba.config, "CACHE_DIR", "") or "")
    if not folder:
        return tabulate()
    target = Path(folder) / "fuzzy_surfaces" / f"{_surface_digest(compiled)}.npz"
    try:
        with np.load(target, allow_pickle=False) as stored:
            return Surface(*(stored[name] for name in SURFACE_FIELDS))
    except (OSError, KeyError, ValueError, EOFError, zipfile.BadZipFile):
        pass  # not stored yet, or unreadable: tabulate (and store) it
    surface = tabulate()
    arrays = {name: getattr(surface, name) for name in SURFACE_FIELDS}
    with contextlib.suppress(OSError):
        write_handle_atomically(target, lambda handle: np.savez(handle, **arrays))
    return surface


def _surface_digest(compiled: CompiledMamdani) -> str:
    digest = hashlib.sha256(_code_digest().encode())
    i, o = compiled.inputs, compiled.outputs
    parts = (i.mf, i.meta, i.support, o.mf, o.meta, o.support, compiled.ant, compiled.cons,
             np.array([compiled.system.surface_points]))
    for part in parts:
        digest.update(f"{part.dtype}{part.shape}".encode())
        digest.update(np.ascontiguousarray(part).tobytes())
    return digest.hexdigest()[:32]


@functools.cache
def _code_digest() -> str:
    digest = hashlib.sha256()
    for source in (Path(__file__).with_name("kernels.py"), Path(__file__)):
        digest.update(source.read_bytes())
    return digest.hexdigest()


@functools.lru_cache(maxsize=32)
def compile_system(system: FuzzySystem) -> CompiledMamdani | CompiledProduct:
    """Compile a definition to kernel arrays (cached per definition; see also ``.compiled``).

    A two-input Mamdani system also gets its :class:`Surface`, tabulated by the exact
    compiled inference at ``surface_points`` nodes per input plus one point per square.
    """
    inputs = SampledVariables.of(system.inputs)
    ant = system.antecedent_indices()
    cons = system.consequent_indices()
    if system.kind == PRODUCT:
        centres = np.array(
            [[var.sets[c].centre for c in cons[:, o]] for o, var in enumerate(system.outputs)]
        )
        return CompiledProduct(system, inputs, ant, centres)
    compiled = CompiledMamdani(system, inputs, SampledVariables.of(system.outputs), ant, cons)
    return compiled.with_surface() if len(system.inputs) == 2 else compiled


register_compiler(compile_system)  # FuzzySystem.compiled



def evaluate(
    system: FuzzySystem, inputs: ArrayLike, *, method: str = "auto", theta: ArrayLike | None = None
) -> Array:
    """Evaluate a fuzzy system on a batch of crisp inputs.

    Args:
        system: The definition (compiled on first use, then cached).
        inputs: (B, n_in) crisp inputs, finite; clipped to the input universes.
        method: Mamdani only: ``"surface"`` (the precomputed surface, two inputs only),
            ``"exact"`` (compiled inference matching skfuzzy) or ``"auto"`` (the surface
            when there is one).
        theta: Product / centre-average only: (n_out, L) consequent centres; default the
            initial ones (:func:`initial_theta`).

    Returns:
        (B, n_out) outputs.

    Raises:
        ValueError: on misshaped or non-finite ``inputs`` or ``theta``, or an option that
            does not apply to the system's kind.
    """
    compiled: CompiledMamdani | CompiledProduct = system.compiled
    x = check_inputs(system, inputs)
    if isinstance(compiled, CompiledProduct):
        if method != "auto":
            raise ValueError(f"method applies to mamdani systems only, got {method!r}")
        return _product_eval(compiled, x, theta)[1]
    if theta is not None:
        raise ValueError("theta applies to product_centre_average systems only")
    choice(method, "method", ("auto", "surface", "exact"))
    if method == "exact" or (method == "auto" and compiled.surface is None):
        return compiled.exact(x)
    return compiled.lookup(x)


def basis(system: FuzzySystem, inputs: ArrayLike) -> Array:
    """Fuzzy basis functions of a product / centre-average system.

    Args:
        system: A ``product_centre_average`` system.
        inputs: (B, n_in) crisp inputs, finite; clipped to the input universes.

    Returns:
        (B, L) basis functions ``xi``; each row sums to 1 (all zeros if no rule fires).
    """
    compiled: CompiledMamdani | CompiledProduct = system.compiled
    x = check_inputs(system, inputs)
    if not isinstance(compiled, CompiledProduct):
        raise ValueError(f"basis needs a {PRODUCT} system, got kind {system.kind!r}")
    return _product_eval(compiled, x, None)[0]


def initial_theta(system: FuzzySystem) -> Array:
    """(n_out, L) initial consequent centres of a product / centre-average system."""
    compiled: CompiledMamdani | CompiledProduct = system.compiled
    if not isinstance(compiled, CompiledProduct):
        raise ValueError(f"initial_theta needs a {PRODUCT} system, got kind {system.kind!r}")
    return compiled.theta0.copy()


def _product_eval(
    compiled: CompiledProduct, x: Array, theta: ArrayLike | None
) -> tuple[Array, Array]:
    th = (
        compiled.theta0
        if theta is None
        else as_finite_array(theta, "theta", shape=compiled.theta0.shape)
    )
    xi = np.empty((x.shape[0], compiled.ant.shape[0]))
    out = np.empty((x.shape[0], th.shape[0]))
    i = compiled.inputs
    _product_batch(i.mf, i.meta, compiled.ant, np.ascontiguousarray(th), x, xi, out)
    return xi, out

