import pickle

import numba
import numpy as np

from contour_gym._blob import Blob, borrow, flat, rows2, rows3, view1, view2, view3


@numba.njit
def _fill_rows(buf, lay):  # type: ignore[no-untyped-def]
    # writes through a borrowed blob's row tables, as the loop kernel does
    fb = borrow(buf)
    t2, t3 = rows2(fb, lay, 0), rows3(fb, lay, 1)
    for i in range(t2.shape[0]):
        for j in range(t2.shape[1]):
            t2[i, j] = 10.0 * i + j
    for i in range(t3.shape[0]):
        t3[i, i % t3.shape[1], 0] = -1.0 - i
    return view3(fb, lay, 0)[1, 0, 2]


def test_row_tables_merge_leading_dimensions_and_alias_the_blob():
    blob = Blob([("a", (2, 3, 4)), ("b", (2, 3, 4, 5))])
    got = _fill_rows(blob.buffer, blob.layout)
    a, b = blob.views["a"], blob.views["b"]
    assert got == a[1, 0, 2] == 10.0 * 3 + 2  # row 3 = member 1, axis 0
    assert np.array_equal(a.reshape(6, 4), 10.0 * np.arange(6)[:, None] + np.arange(4))
    flat_b = b.reshape(6, 4, 5)
    for i in range(6):
        assert flat_b[i, i % 4, 0] == -1.0 - i
    assert np.count_nonzero(b) == 6


def test_pickled_blob_views_alias_the_new_buffer():
    blob = Blob([("a", (2, 3)), ("b", (4,))])
    blob.views["b"][:] = 7.0
    copy = pickle.loads(pickle.dumps(blob))
    copy.buffer[:] = 1.0
    assert np.all(copy.views["a"] == 1.0) and np.all(copy.views["b"] == 1.0)
    assert np.all(blob.views["b"] == 7.0)


@numba.njit
def _all_views(buf, lay):  # type: ignore[no-untyped-def]
    return (view1(buf, lay, 0).copy(), view2(buf, lay, 1).copy(), view3(buf, lay, 2).copy(),
            rows2(buf, lay, 3).copy(), rows3(buf, lay, 3).copy(), flat(buf, lay, 2).copy(),
            view2(buf, lay, 4).copy())


def test_carved_views_equal_numpy_views_of_every_shape():
    blob = Blob([("a", (3,)), ("b", (2, 5)), ("c", (2, 3, 4)), ("d", (2, 2, 3, 2)), ("e", (0, 4))])
    blob.buffer[:] = np.arange(blob.buffer.size)
    v = blob.views
    got = _all_views(blob.buffer, blob.layout)
    want = (v["a"], v["b"], v["c"], v["d"].reshape(-1, 2), v["d"].reshape(-1, 3, 2),
            v["c"].ravel(), v["e"])
    for g, w in zip(got, want, strict=True):
        assert g.shape == w.shape and np.array_equal(g, w)
