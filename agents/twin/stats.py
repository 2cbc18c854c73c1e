"""How well the logs determine a fit's values: their deviations, the residuals' correlation.

Each takes the fitted replay (:class:`Fitted`: its residual rows per axis and channel) with
its residuals ``res`` (R,) and Jacobian ``jac`` (R, A P) at the fit; the axes are fitted
apart, so each axis's values are judged by its own rows and columns.
"""

from __future__ import annotations

from typing import Protocol

import numpy as np
from numpy.typing import NDArray

Array = NDArray[np.float64]


class Fitted(Protocol):
    """What these read of a fitted replay: its unknowns and its residual rows."""

    names: list[tuple[str, ...]]
    n_params: int
    channel_axis: NDArray[np.int_]

    def channel_rows(self, total: int) -> list[NDArray[np.intp]]: ...  # noqa: D102

    def axis_rows(self, total: int) -> list[NDArray[np.intp]]: ...  # noqa: D102


def deviations(problem: Fitted, res: Array, jac: Array) -> Array:
    """(A P,) standard deviations of the log factors, the residuals' correlation counted.

    Per axis (the axes are fitted apart): ``sqrt(diag((J'J)^-1) r'r / n_eff)``, with
    ``n_eff`` the axis's residual samples over their integrated autocorrelation time. A model
    that misses something leaves long-correlated residuals: few effective samples, and wide
    deviations for the parameters that trade off against what it misses.
    """
    a, p = len(problem.names), problem.n_params
    out = np.zeros(a * p)
    channels = problem.channel_rows(res.size)
    for ax, rows in enumerate(problem.axis_rows(res.size)):
        n_eff = sum(len(r) / correlation_time(res[r]) for r, c
                    in zip(channels, problem.channel_axis, strict=True) if c == ax)
        cols = slice(ax * p, (ax + 1) * p)
        cov = np.linalg.pinv(jac[rows, cols].T @ jac[rows, cols])
        variance = float(res[rows] @ res[rows]) / max(n_eff - p, 1.0)
        out[cols] = np.sqrt(np.clip(np.diag(cov), 0.0, None) * variance)
    return out


def correlation_time(e: Array) -> float:
    """Integrated autocorrelation time of ``e``, samples (1 for white residuals).

    ``1 + 2 sum rho(k)`` over the lags up to the first whose autocorrelation is not positive.
    """
    e = e - e.mean()
    n = len(e)
    spectrum = np.fft.rfft(e, 2 * n)
    acf = np.fft.irfft(spectrum * np.conj(spectrum))[:n]
    if acf[0] <= 0.0:
        return 1.0
    rho = acf[1:] / acf[0]
    stop = np.flatnonzero(rho <= 0.0)
    return float(1.0 + 2.0 * rho[: stop[0] if stop.size else n - 1].sum())
