"""summit_nav_common.distance: the exact Euclidean distance field."""
import math

import numpy as np
import pytest

from summit_nav_common.distance import distance_field


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
