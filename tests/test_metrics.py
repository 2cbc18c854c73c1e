import numpy as np
import pytest

from contour_gym.metrics import ErrorSums, metrics_from_sums, sums_from_trace


def test_metrics_on_known_arrays():
    eps = np.array([[[1.0, -2.0], [-3.0, 0.0]]])  # B=1, T=2, C=2
    e = np.array([[[1.0, 0.0, -2.0], [3.0, 1.0, 0.0]]])  # A=3
    u = np.array([[[1.0, 0.0, 0.0], [0.0, 2.0, 0.0]]])
    m = metrics_from_sums(sums_from_trace(eps, e, u), 2.5)
    assert m["max_contour_error"][0] == 3.0
    assert m["mean_contour_error"][0] == pytest.approx(6.0 / 4)
    assert m["rms_contour_error"][0] == pytest.approx(np.sqrt(14.0 / 4))
    assert m["p_eps"][0] == pytest.approx((1 + 3) / 2 + (2 + 0) / 2)  # 003 eq. 40
    assert m["p_e"][0] == pytest.approx((1 + 3) / 2 + (0 + 1) / 2 + (2 + 0) / 2)  # 003 eq. 39
    assert m["chattering"][0] == pytest.approx(1 + 1 + 2)
    assert m["cycle_time"][0] == 2.5
    assert m["max_tracking_error"][0].tolist() == [3.0, 1.0, 2.0]
    assert m["peak_tracking_error"][0] == 3.0  # the largest axis's


def test_zeros_give_zero_metrics():
    m = metrics_from_sums(ErrorSums.zeros(3, 2, 2), np.array([1.0, 2.0, np.inf]))
    assert np.all(m["max_contour_error"] == 0) and m["cycle_time"][2] == np.inf
