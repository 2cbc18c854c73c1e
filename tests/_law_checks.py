"""Checks shared by the tests of the compiled CCC laws (tests/test_ccc_laws.py and others)."""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
import pytest

from contour_gym.ccc import CCCLaw, ccc_params
from contour_gym.loop import ServoLoop


def assert_members_equal_single_runs(
    make_loop: Callable[..., ServoLoop], law: str, rows: Sequence[dict[str, float]], ticks: int
) -> None:
    """Members of one batch, each with its own law parameters, equal single runs bit for bit.

    Args:
        make_loop: ``make_loop(law, params, batch=B)`` -> a reset loop that records.
        law: The CCC law.
        rows: Each member's law parameters (the same names in every row); the first and the
            last must differ in their effect.
        ticks: Ticks to run.
    """
    batch = make_loop(law, {}, batch=len(rows))
    batch.set_ccc_params(**{k: np.array([[r[k]] for r in rows]) for k in rows[0]})
    batch.step(ticks)
    for b, params in enumerate(rows):
        single = make_loop(law, params)
        single.step(ticks)
        np.testing.assert_array_equal(batch.ccc_p[b], single.ccc_p[0])
        np.testing.assert_array_equal(batch.trace().eps_est[b], single.trace().eps_est[0])
        np.testing.assert_array_equal(batch.trace().u[b], single.trace().u[0])
        np.testing.assert_array_equal(batch.ccc_s[b], single.ccc_s[0])
    assert not np.array_equal(batch.trace().u[0], batch.trace().u[-1])


def assert_ccc_params_name_the_bad_value(
    law: CCCLaw, base: Sequence[float], name: str, value: float
) -> None:
    """:func:`contour_gym.ccc.ccc_params` refuses a bad ``value`` of ``name``, naming both.

    ``name`` ``"kp"`` puts the value in the base gains (named ``ccc_gains``), any other name
    into the law's parameters; an unknown parameter is refused by its name too.
    """
    with pytest.raises(ValueError, match=rf"{'ccc_gains' if name == 'kp' else name}.*{value}"):
        if name == "kp":
            ccc_params((value, 0.0, 0.0), 1, 1, law)
        else:
            ccc_params(base, 1, 1, law, **{name: value})
    with pytest.raises(ValueError, match="k_typo"):
        ccc_params(base, 1, 1, law, k_typo=1.0)


def assert_runs_as_the_pid_law(
    make_loop: Callable[..., ServoLoop], law: str, params: dict[str, float], ticks: int
) -> tuple[ServoLoop, ServoLoop]:
    """``law`` with ``params`` drives the machine as the ``pid`` law does, bit for bit.

    Returns:
        The law's loop and the pid law's, after ``ticks`` ticks (for checks of their state).
    """
    loop, pid = make_loop(law, params), make_loop("pid", {})
    loop.step(ticks)
    pid.step(ticks)
    a, b = loop.trace(), pid.trace()
    np.testing.assert_array_equal(a.u, b.u)
    np.testing.assert_array_equal(a.eps_est, b.eps_est)
    np.testing.assert_array_equal(a.x, b.x)
    return loop, pid
