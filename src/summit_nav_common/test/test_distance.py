"""summit_nav_common.distance: the exact Euclidean distance field, whole and bounded."""
import math

import numpy as np
import pytest

from summit_nav_common.distance import bounded_distance_field, distance_field


def test_distance_field_is_euclidean():
    occ = np.zeros((9, 9), bool)
    occ[4, 4] = True
    d = distance_field(occ)
    assert d[4, 4] == 0
    assert d[4, 7] == pytest.approx(3.0, abs=1e-3)
    assert d[0, 0] == pytest.approx(math.hypot(4, 4), abs=1e-2)



def test_distance_field_matches_brute_force():
    """Exact Euclidean distance to the nearest occupied cell centre, against every
    occupied cell by brute force, on random grids (non-square, sparse and dense)."""
    rng = np.random.default_rng(3)
    for shape, p in (((13, 21), 0.05), ((30, 17), 0.3), ((8, 8), 0.9)):
        occ = rng.random(shape) < p
        d = distance_field(occ)
        assert d.dtype == np.float32 and d.shape == shape
        oy, ox = np.nonzero(occ)
        yy, xx = np.mgrid[0:shape[0], 0:shape[1]]
        brute = np.min(np.hypot(yy[..., None] - oy, xx[..., None] - ox), axis=-1)
        np.testing.assert_allclose(d, brute, rtol=1e-6, atol=1e-6)


def test_distance_field_without_obstacles_or_free_cells():
    assert (distance_field(np.zeros((3, 4), bool)) == 7.0).all()
    assert (distance_field(np.ones((3, 4), bool)) == 0.0).all()


@pytest.mark.parametrize("limit", [0.0, 1.0, 2.5, 6.0, 41.0, 100.0])
def test_bounded_field_equals_the_full_field_within_its_limit(limit):
    """bounded_distance_field (numpy, for amcl's capped likelihood field) gives distance_field's
    very float32 values up to the limit and only values above it beyond, on random
    grids of several densities and shapes (a row, a column, non-square)."""
    rng = np.random.default_rng(int(limit * 10))
    for shape, p in (((13, 21), 0.05), ((60, 47), 0.01), ((8, 8), 0.5), ((1, 40), 0.1), ((40, 1), 0.1)):
        occ = rng.random(shape) < p
        occ.flat[rng.integers(occ.size)] = True
        bounded = bounded_distance_field(occ, limit)
        assert bounded.dtype == np.float32 and bounded.shape == shape
        full = distance_field(occ) if not occ.all() else np.zeros(shape, np.float32)
        within = full <= limit
        np.testing.assert_array_equal(bounded[within], full[within])
        assert (bounded[~within] > limit).all()


def test_bounded_field_without_obstacles_is_beyond_its_limit():
    assert (bounded_distance_field(np.zeros((3, 4), bool), 2.0) > 2.0).all()
    assert (bounded_distance_field(np.ones((3, 4), bool), 2.0) == 0.0).all()
