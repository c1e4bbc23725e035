"""Patched occupancy grid: ray tracing, OccupancyGrid output, copy-on-write sharing."""
import math

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from my_summit_mapping import grid as G
from summit_nav_common.testing.scenes import ANGLES, ray_cast

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


@pytest.mark.parametrize("no_hit_every", [0, 5])
def test_fast_ray_tracing_matches_reference(no_hit_every):
    """trace_scan against the per-beam walk; with no_hit, those beams free their line
    (their end cell untouched) and mark nothing."""
    pose = np.array([0.37, -0.21, 0.4])
    ranges = ray_cast(pose)
    ranges[::7] = np.nan
    no_hit = np.zeros(len(ranges), bool)
    if no_hit_every:
        no_hit[::no_hit_every] = True
    res = 0.047  # not a divisor of the wall coordinates: no endpoint on a cell boundary [m]
    ix0, iy0, counts = G.trace_scan(pose, ranges, ANGLES, 8.0, 29.0, res, no_hit)
    ref = G.trace_scan_reference(pose, ranges, ANGLES, 8.0, 29.0, res, no_hit)
    if no_hit_every:
        plain = G.trace_scan(pose, ranges, ANGLES, 8.0, 29.0, res)[2]
        assert counts[G.HITS].sum() < plain[G.HITS].sum()
        assert counts[G.HITS].sum() == np.sum(np.isfinite(ranges) & ~no_hit & (ranges < 8.0))
    fast = np.zeros_like(counts)
    for (x, y), layers in ref.items():
        fast[:, y - iy0, x - ix0] = layers          # raises if the window misses a cell
    # per-beam counts, cell for cell
    assert_array_equal(counts, fast)
    assert counts[G.VISITS].max() > 50              # near the laser every beam passes


def test_counts_per_beam_keep_a_wall_thin():
    """A cell in front of a wall that one noisy beam per scan ends in stays free, as in
    gmapping, which counts every beam: 1 hit against the visits of the 40 beams passing
    through it (counted once per scan, it was 1 hit / 1 visit: occupied)."""
    g = G.PatchGrid(RES)
    laser = np.array([0.0125, 0.025, 0.0])
    angles = np.linspace(-0.01, 0.01, 41)       # all beams stay in the row y in [0, 0.05)
    ranges = (1.01 - laser[0]) / np.cos(angles)  # the wall face at x = 1.0 m, hits at 1.01 m
    ranges[20] = 0.99 - laser[0]                 # laser noise: one beam short, in column 19
    for _ in range(5):
        g.integrate_scan(laser, ranges, angles, 10.0, 30.0)
    hits, visits = g.read_window(19, 0, 2, 1)
    assert_array_equal(hits[0], [5, 200]) and assert_array_equal(visits[0], [205, 200])
    assert hits[0, 0] / visits[0, 0] < G.FULLNESS_THRESHOLD < hits[0, 1] / visits[0, 1]
    assert_array_equal(G.occupied_mask(hits, visits)[0], [False, True])


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


def test_counters_halve_keeping_the_frequency(monkeypatch):
    monkeypatch.setattr(G, "COUNT_LIMIT", 255)
    g = G.PatchGrid(RES)
    for _ in range(600):
        g.integrate_scan(np.array([0.025, 0.025, 0.0]), np.array([1.01]), np.array([0.0]), 10.0, 30.0)
    hits, visits = g.read_window(0, 0, 21, 1)
    assert visits.max() <= 255
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


def test_bresenham_float_division_is_exact():
    """The float64 division in bresenham_cells gives the integer formula's cells exactly,
    also at exact halves (d / n = 1/2, 3/2, ...) and far from the origin."""
    rng = np.random.default_rng(3)
    start = rng.integers(-5000, 5000, size=(3000, 2))
    stop = start + rng.integers(-400, 401, size=(3000, 2))
    stop[:500, 1] = start[:500, 1] + (stop[:500, 0] - start[:500, 0]) // 2   # halves
    cells, beam = G.bresenham_cells(start, stop)
    d = stop - start
    n = np.abs(d).max(axis=1)
    k = np.concatenate([np.arange(m + 1) for m in n])
    nn = np.maximum(n, 1)[beam]
    expected = start[beam] + (2 * k[:, None] * d[beam] + nn[:, None]) // (2 * nn[:, None])
    assert_array_equal(cells, expected)
    assert_array_equal(cells[np.r_[0, np.cumsum(n + 1)[:-1]]], start)     # lines start ...
    assert_array_equal(cells[np.cumsum(n + 1) - 1], stop)                  # ... and end right


def test_compiled_tracing_matches_numpy_trace():
    """integrate_scan (compiled, into the pool) adds exactly trace_scan's window, hit sums
    included, also over patches shared with a copy (which stays unchanged)."""
    pose = np.array([0.37, -0.21, 0.4])
    ranges = ray_cast(pose)
    ranges[::7] = np.nan
    ranges[3::11] = np.inf                          # no return: skipped
    ranges[5::13] = 12.0                            # beyond maxUrange: free up to it, no hit
    res = 0.047
    g = G.PatchGrid(res)
    g.integrate_scan(pose + [0.2, 0.1, 0.3], ray_cast(pose + [0.2, 0.1, 0.3]), ANGLES, 8.0, 29.0)
    before = g.copy()
    no_hit = np.zeros(len(ranges), bool)
    no_hit[2::9] = True                             # free their line, mark nothing
    ix0, iy0, counts = G.trace_scan(pose, ranges, ANGLES, 8.0, 29.0, res, no_hit)
    _, h, w = counts.shape
    expected = before.read_layers(ix0, iy0, w, h) + counts
    g.integrate_scan(pose, ranges, ANGLES, 8.0, 29.0, no_hit)
    assert_allclose(g.read_layers(ix0, iy0, w, h), expected, rtol=1e-6, atol=1e-6)
    assert_array_equal(g.read_layers(ix0, iy0, w, h)[:G.SUM_X], expected[:G.SUM_X])   # counts exact
    assert_allclose(before.read_layers(ix0, iy0, w, h), expected - counts, atol=1e-6)
    assert g.bounds() is not None


def test_mean_hit_point_and_skipped_no_returns():
    g = G.PatchGrid(RES)
    laser = np.array([0.01, 0.01, 0.0])
    # two hits in cell (20, 0) at x = 1.012 and 1.032 (y = 0.01); +inf and 40 m (> maxRange 30) skipped
    g.integrate_scan(laser, np.array([1.002, 1.022, np.inf, 40.0]), np.array([0.0, 0.0, 1.0, 2.0]), 10.0, 30.0)
    assert g.mean_hit(20, 0) == pytest.approx((1.022, 0.01), abs=1e-6)
    assert g.mean_hit(19, 0) is None
    hits, visits = g.read_window(-300, -300, 600, 600)
    assert hits.sum() == 2 and visits.sum() == 2 * 21      # only the two beams were traced


def test_pool_slots_are_reused_when_maps_are_dropped():
    g = G.PatchGrid(RES, G.PatchPool(4))
    g.integrate_scan(np.array([0.0, 0.0, 0.0]), ray_cast((0.0, 0.0, 0.0)), ANGLES, 8.0, 30.0)
    pool = g.pool
    used = pool.used()
    assert used == g.patch_count() > 4              # the pool grew past its 4 slots
    copies = [g.copy() for _ in range(3)]
    for c in copies:
        c.integrate_scan(np.array([0.01, 0.01, 0.0]), np.array([0.5]), np.array([0.0]), 8.0, 30.0)
    assert pool.used() == used + 3                   # one copied patch each
    del copies, c
    assert pool.used() == used                       # released when dropped
    g.release()
    assert pool.used() == 0 and g.patch_count() == 0


def test_add_hits_marks_end_cells_only():
    """gmapping's registerScan without generateMap: a hit (and its point) in each end
    cell, nothing along the beam; beyond maxUrange or maxRange, +inf, NaN: skipped."""
    g = G.PatchGrid(RES)
    laser = np.array([0.01, 0.01, 0.0])
    g.add_hits(laser, np.array([1.002, 1.022, 12.0, np.inf, np.nan, 0.0]), np.zeros(6), 10.0, 30.0)
    hits, visits = g.read_window(-300, -300, 600, 600)
    assert hits.sum() == 2 and visits.sum() == 2
    assert g.read_window(20, 0, 1, 1)[0][0, 0] == 2
    assert g.mean_hit(20, 0) == pytest.approx((1.022, 0.01), abs=1e-6)
    g.add_hits(laser, np.array([10.0]), np.zeros(1), 10.0, 30.0)    # r == maxUrange: used
    assert g.read_window(-300, -300, 600, 600)[0].sum() == 3


def _read_layers_reference(g, ix0, iy0, width, height):
    """read_layers cell by cell: each cell from its patch, or zeros (the oracle)."""
    out = np.zeros((G.LAYERS, height, width), np.float32)
    store = g.pool.store
    for r in range(height):
        for c in range(width):
            ix, iy = ix0 + c, iy0 + r
            slot = g._patches.get((iy >> G.PATCH_SHIFT, ix >> G.PATCH_SHIFT))
            if slot is not None:
                out[:, r, c] = store[slot, :, iy & (G.PATCH_CELLS - 1), ix & (G.PATCH_CELLS - 1)]
    return out


@pytest.mark.parametrize("window", [(-37, -21, 75, 50), (3, 5, 1, 1), (-64, -64, 128, 128), (-200, -7, 40, 9),
                                    (11, -40, 33, 90), (-500, -420, 1000, 900)])
def test_read_layers_matches_reading_cell_by_cell(window):
    """The scatter into a patch-aligned buffer, by window or by allocated patches, reads
    what each cell's patch holds, unallocated cells as 0, for windows off patch borders,
    of one cell, on them, outside the grid, across it, and far larger than it (the
    allocated patches enumerated instead of the window's)."""
    g = G.PatchGrid(RES)
    rng = np.random.default_rng(4)
    for _ in range(6):
        pose = np.array([rng.uniform(-1.5, 1.5), rng.uniform(-1.0, 1.0), rng.uniform(-3, 3)])
        g.integrate_scan(pose, ray_cast(pose), ANGLES, 8.0, 29.0)
    ix0, iy0, w, h = window
    expected = _read_layers_reference(g, ix0, iy0, w, h)
    assert_array_equal(g.read_layers(ix0, iy0, w, h), expected)
    assert_array_equal(g.read_layers(ix0, iy0, w, h, layers=2), expected[:2])
    assert_array_equal(G.PatchGrid(RES).read_layers(ix0, iy0, w, h), np.zeros_like(expected))
