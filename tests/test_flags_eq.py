"""numba's compiler flags compare and hash as numba's own methods do, with faster ones."""

from __future__ import annotations

import itertools

from numba.core.compiler import Flags
from numba.core.targetconfig import TargetConfig

import contour_gym  # noqa: F401  (installs it)
from contour_gym.jit import flags_eq


def _numba_equal(a: Flags, b: Flags) -> bool:
    return a.values() == b.values()


def _numba_hash(a: Flags) -> int:
    return hash(tuple(sorted(a.values())))


def test_it_is_installed_and_installing_again_changes_nothing() -> None:
    installed = TargetConfig.__eq__, TargetConfig.__hash__
    assert all(getattr(method, "wrapped", None) is not None for method in installed)
    assert flags_eq.install()
    assert (TargetConfig.__eq__, TargetConfig.__hash__) == installed


def test_flags_compare_as_numba_compares_them() -> None:
    variants = []
    choices = itertools.product((None, True, False), (None, True, False), (False, True))
    for nrt, boundscheck, explicit_default in choices:
        flags = Flags()
        if nrt is not None:
            flags.nrt = nrt
        if boundscheck is not None:
            flags.boundscheck = boundscheck
        if explicit_default:  # set to its default: equal to leaving it unset
            flags.fastmath = Flags().fastmath
        variants.append(flags)
    for a, b in itertools.product(variants, repeat=2):
        assert (a == b) is _numba_equal(a, b)
        assert hash(a) == _numba_hash(a)
    assert Flags() != 1
