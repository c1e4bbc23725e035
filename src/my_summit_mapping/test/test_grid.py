"""Patched occupancy grid: ray tracing, OccupancyGrid output, copy-on-write sharing."""
import math

import numpy as np
import pytest
from numpy.testing import assert_array_equal

from my_summit_mapping import grid as G
from synthetic_world import ANGLES, ray_cast

RES = 0.05  # [m]


def _occ(g, extent=(-1.0, -1.0, 1.0, 1.0)):
    data, w, h, res, ox, oy = g.occupancy_grid(0.25, extent)
    return data.reshape(h, w), ox, oy


def test_single_beam_marks_hit_and_free_cells():
    g = G.PatchGrid(RES)
    # laser at the centre of cell (0, 0) looking along +x; hit 1.0 m away -> cell (20, 0)
    g.integrate_scan(np.array([0.025, 0.025, 0.0]), np.array([1.0]), np.array([0.0]), 10.0, 30.0)
    grid, ox, oy = _occ(g)
    assert (ox, oy) == (-1.0, -1.0)
    row = grid[int(round((0.0 - oy) / RES))]           # the row of cells y in [0, 0.05)
    col0 = int(round((0.0 - ox) / RES))                 # the column of cells x in [0, 0.05)
    assert row[col0 + 20] == G.OCCUPIED
    assert_array_equal(row[col0:col0 + 20], G.FREE)
    assert row[col0 + 21] == G.UNKNOWN and row[col0 - 1] == G.UNKNOWN
    assert (grid == G.OCCUPIED).sum() == 1 and (grid == G.FREE).sum() == 20


def test_no_return_beams_free_up_to_max_urange_only():
    g = G.PatchGrid(RES)
    ranges = np.array([np.nan, np.inf, 40.0, 2.0, 0.0])   # no return x3 (>= maxRange 30), too long, ignored
    angles = np.array([0.0, 0.5, 1.0, 1.5, 2.0])
    g.integrate_scan(np.array([0.0, 0.0, 0.0]), ranges, angles, 1.0, 30.0)
    grid, _, _ = _occ(g, (-3.0, -3.0, 3.0, 3.0))
    assert (grid == G.OCCUPIED).sum() == 0               # nothing returned within maxUrange
    free = np.argwhere(grid == G.FREE) * RES - 3.0 + RES / 2   # cell centres [m]
    assert np.hypot(free[:, 1], free[:, 0]).max() < 1.0 + RES  # nothing beyond maxUrange


def test_fast_ray_tracing_matches_reference():
    pose = np.array([0.37, -0.21, 0.4])
    ranges = ray_cast(pose)
    ranges[::7] = np.nan
    res = 0.047  # not a divisor of the wall coordinates: no endpoint on a cell boundary [m]
    ix0, iy0, hits, visits = G.trace_scan(pose, ranges, ANGLES, 8.0, 29.0, res)
    free_ref, hit_ref = G.trace_scan_reference(pose, ranges, ANGLES, 8.0, 29.0, res)
    hit_fast = {(ix0 + c, iy0 + r) for r, c in np.argwhere(hits)}
    vis_fast = {(ix0 + c, iy0 + r) for r, c in np.argwhere(visits)}
    assert hit_fast == hit_ref
    assert hit_fast <= vis_fast
    # 8-connected lines skip the corner-cut cells a fine walk collects, and may round a
    # cell either way: everything must agree to within one cell.
    near_ref = {(x + dx, y + dy) for x, y in free_ref for dx in (-1, 0, 1) for dy in (-1, 0, 1)}
    near_fast = {(x + dx, y + dy) for x, y in vis_fast for dx in (-1, 0, 1) for dy in (-1, 0, 1)}
    assert vis_fast <= near_ref
    assert free_ref <= near_fast
    assert len(vis_fast) > 0.6 * len(free_ref)


def test_copy_shares_patches_until_written():
    g = G.PatchGrid(RES)
    g.integrate_scan(np.array([0.0, 0.0, 0.0]), ray_cast((0.0, 0.0, 0.0)), ANGLES, 8.0, 30.0)
    n = g.patch_count()
    assert n > 4 and g.owned_patch_count() == n
    c = g.copy()
    assert c.patch_count() == n
    assert c.owned_patch_count() == 0 and g.owned_patch_count() == 0
    assert all(c.shares_patch_with(g, k) for k in g._patches)
    assert len(g.patch_ids() | c.patch_ids()) == n        # no patch memory was copied
    before = g.occupancy_grid(0.25)[0].copy()
    # one short beam touches one patch: only that patch is duplicated, in the copy only
    c.integrate_scan(np.array([0.01, 0.01, 0.0]), np.array([0.5]), np.array([0.0]), 8.0, 30.0)
    assert c.owned_patch_count() == 1
    assert len(g.patch_ids() | c.patch_ids()) == n + 1
    assert sum(not c.shares_patch_with(g, k) for k in g._patches) == 1
    assert_array_equal(g.occupancy_grid(0.25)[0], before)  # the original is unchanged
    # the writer now owns the patch: writing again does not copy again
    c.integrate_scan(np.array([0.01, 0.01, 0.0]), np.array([0.5]), np.array([0.0]), 8.0, 30.0)
    assert len(g.patch_ids() | c.patch_ids()) == n + 1


def test_counters_saturate_keeping_the_frequency():
    g = G.PatchGrid(RES)
    for _ in range(600):
        g.integrate_scan(np.array([0.025, 0.025, 0.0]), np.array([1.0]), np.array([0.0]), 10.0, 30.0)
    hits, visits = g.read_window(0, 0, 21, 1)
    assert visits.max() <= G.COUNT_LIMIT
    assert hits[0, 20] == visits[0, 20] and visits[0, 20] > 100
    assert hits[0, :20].max() == 0


def test_occupancy_grid_grows_beyond_extent_and_entropy():
    g = G.PatchGrid(RES)
    assert g.entropy() == 0.0
    g.integrate_scan(np.array([0.0, 0.0, 0.0]), np.array([5.0]), np.array([0.0]), 10.0, 30.0)
    data, w, h, res, ox, oy = g.occupancy_grid(0.25, (-1.0, -1.0, 1.0, 1.0))
    assert data.dtype == np.int8 and data.size == w * h and res == RES
    assert ox == -1.0 and ox + w * res >= 5.0 and oy == -1.0
    assert g.entropy() == 0.0                      # every seen cell is certain (all 0 or 1)
    g.integrate_scan(np.array([0.0, 0.0, 0.0]), np.array([3.0]), np.array([0.0]), 10.0, 30.0)
    # the cell at 3 m: 1 hit / 2 visits -> ln 2; at 5 m: 1/1 -> 0
    assert g.entropy() == pytest.approx(math.log(2.0))


def test_bad_resolution():
    with pytest.raises(ValueError):
        G.PatchGrid(0.0)
