"""Correlative scan matcher: the vectorized search equals the slow oracle; the branch and
bound equals the exhaustive search; known offsets are recovered; the covariance is long
along a corridor."""
import math

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from my_summit_mapping.karto import correlative_matcher as cm
from summit_nav_common.testing.scenes import ANGLES, ray_cast

SEARCH = cm.SearchSpace(dimension=0.3, resolution=0.01, smear_deviation=0.03)
SETTINGS = cm.MatcherSettings()


def _points(pose, angles=ANGLES, segments=None):
    """Base-frame hit points (n, 2) of a scan from pose in the room (laser at the base)."""
    r = ray_cast(pose, angles) if segments is None else ray_cast(pose, angles, segments)
    ok = np.isfinite(r)
    return np.column_stack((r[ok] * np.cos(angles[ok]), r[ok] * np.sin(angles[ok])))


def _to_map(pose, pts):
    c, s = math.cos(pose[2]), math.sin(pose[2])
    return np.column_stack((pose[0] + c * pts[:, 0] - s * pts[:, 1], pose[1] + s * pts[:, 0] + c * pts[:, 1]))


def test_stamped_grid_is_the_max_of_the_kernels():
    rng = np.random.default_rng(3)
    pts = rng.uniform(-0.2, 0.2, (25, 2))
    grid = cm.LookupGrid.build(pts, 0.01, 0.03, np.zeros(2), 5.0, 3)
    kernel = cm.smear_kernel(0.01, 0.03)
    half = kernel.shape[0] // 2
    expect = np.zeros_like(grid.values)
    for c in {tuple(v) for v in np.floor((pts - grid.origin) / 0.01).astype(int)}:
        win = expect[c[1] - half:c[1] + half + 1, c[0] - half:c[0] + half + 1]
        np.maximum(win, kernel, out=win)
    assert_array_equal(grid.values, expect)
    assert kernel[half, half] == cm.GRID_OCCUPIED


def test_correlate_equals_the_reference():
    rng = np.random.default_rng(1)
    ref = _to_map((0.0, 0.0, 0.0), _points((0.0, 0.0, 0.0), ANGLES[::24]))
    pts = _points((0.05, -0.03, 0.02), ANGLES[::24])
    center = np.array([0.04, -0.02, 0.03])
    grid = cm.LookupGrid.build(ref, 0.02, 0.03, center[:2], 20.0, 6)
    offsets = cm._offsets(5, 2)
    angles = center[2] + np.linspace(-0.05, 0.05, 5) + rng.uniform(0, 1e-3)
    assert_allclose(cm.correlate(grid, pts, center, offsets, angles),
                    cm.correlate_reference(grid, pts, center, offsets, angles), atol=1e-12)


def test_branch_and_bound_equals_the_exhaustive_search():
    ref = _to_map((0.0, 0.0, 0.0), _points((0.0, 0.0, 0.0), ANGLES[::2]))
    pts = _points((0.7, -0.4, 0.1), ANGLES[::2])
    center = np.array([0.3, 0.1, 0.0])
    search = cm.SearchSpace(4.0, 0.05, 0.03)
    grid = cm.LookupGrid.build(ref, search.resolution, search.smear_deviation, center[:2], 25.0, 41)
    angles = cm._angles(0.0, math.radians(20), math.radians(2))
    full = cm.correlate(grid, pts, center, cm._offsets(40, 2), angles)
    bnb = cm.correlate_bounded(grid, pts, center, 40, 2, angles)
    best = full.max()
    wanted = full >= best - cm.COVARIANCE_RESPONSE_BAND
    assert np.nanmax(bnb) == best
    assert_array_equal(bnb[wanted], full[wanted])
    assert np.isnan(bnb).mean() > 0.5          # it did prune
    # asking only for responses of 0.5 and more prunes nearly everything
    assert np.isnan(cm.correlate_bounded(grid, pts, center, 40, 2, angles, floor=0.5)).mean() > 0.8


def test_recovers_a_known_offset():
    true = np.array([0.3, -0.2, 0.1])
    ref = np.vstack([_to_map(p, _points(p)) for p in ([0.0, 0.0, 0.0], [0.5, 0.3, 0.4], [-0.6, 0.8, -0.5])])
    pts = _points(true)
    matcher = cm.ScanMatcher(SEARCH, SETTINGS, range_threshold=12.0)
    guess = true + np.array([0.09, -0.07, math.radians(6)])
    r = matcher.match(pts, ref, guess)
    assert_allclose(r.pose[:2], true[:2], atol=0.015)
    assert abs(r.pose[2] - true[2]) < math.radians(0.5)
    assert r.response > 0.8
    assert np.all(np.linalg.eigvalsh(r.covariance) > 0)


def test_loop_search_finds_a_far_offset():
    true = np.array([0.3, -0.2, 0.1])
    ref = _to_map((0.0, 0.0, 0.0), _points((0.0, 0.0, 0.0)))
    pts = _points(true)
    loop = cm.ScanMatcher(cm.SearchSpace(8.0, 0.05, 0.03), SETTINGS, 12.0)
    guess = true + np.array([1.6, 1.1, math.radians(12)])
    r = loop.match(pts, ref, guess, penalize=False, refine=False)
    assert_allclose(r.pose[:2], true[:2], atol=0.1)
    assert abs(r.pose[2] - true[2]) < math.radians(2.5)


def test_covariance_is_long_along_a_corridor():
    corridor = np.array([[-20.0, -1.0, 20.0, -1.0], [20.0, 1.0, -20.0, 1.0]])
    angles = np.linspace(-0.3, 0.3, 61) + math.pi / 2     # looking at the walls only
    angles = np.concatenate((angles, angles + math.pi))
    ref = _to_map((0.0, 0.0, 0.0), _points((0.0, 0.0, 0.0), angles, corridor))
    pts = _points((0.0, 0.0, 0.0), angles, corridor)
    r = cm.ScanMatcher(SEARCH, SETTINGS, 12.0).match(pts, ref, np.zeros(3), penalize=False)
    assert r.covariance[0, 0] > 10 * r.covariance[1, 1]


def test_nothing_to_match_gives_a_huge_covariance():
    pts = _points((0.0, 0.0, 0.0))
    r = cm.ScanMatcher(SEARCH, SETTINGS, 12.0).match(pts, np.zeros((0, 2)), np.zeros(3))
    assert r.response == 0.0
    assert r.covariance[0, 0] == cm.MAX_VARIANCE


def test_window_moves_onto_a_best_pose_at_its_edge():
    """A prediction 0.22 m off lies outside the +-0.15 m window: the fixed window (open_karto)
    stops at its edge, the re-centred one reaches the true pose. Unpenalized: with the
    distance penalty the edge (0.557) and a pose 0.05 m from the prediction (0.561) were a
    hair apart in this sparse room, and which won changed between two machines' floating
    point; unpenalized the edge leads by 0.04."""
    true = np.array([0.3, -0.2, 0.1])
    ref = np.vstack([_to_map(p, _points(p)) for p in ([0.0, 0.0, 0.0], [0.5, 0.3, 0.4])])
    pts = _points(true)
    guess = true + np.array([0.22, 0.0, 0.0])
    fixed = cm.ScanMatcher(SEARCH, SETTINGS, 12.0).match(pts, ref, guess, penalize=False)
    moving = cm.ScanMatcher(SEARCH, cm.MatcherSettings(max_recenters=2), 12.0).match(pts, ref, guess,
                                                                                     penalize=False)
    assert abs(fixed.pose[0] - true[0]) > 0.05
    assert_allclose(moving.pose[:2], true[:2], atol=0.015)


def test_covariance_floor_holds_in_every_direction():
    """A diagonal corridor's spread is nearly singular: the floor raises its narrow
    direction, not only the axes, so that its information stays finite."""
    d = np.array([1.0, 1.0]) / math.sqrt(2.0)
    spread = 0.04 * np.outer(d, d) + 1e-9 * np.eye(2)
    floored = cm.floor_eigenvalues(spread, 1e-4)
    assert_allclose(np.linalg.eigvalsh(floored), [1e-4, 0.04 + 1e-9], rtol=1e-6)
    assert_allclose(floored @ d, (0.04 + 1e-9) * d, rtol=1e-6)      # the long axis is kept


def _corridor_scan():
    """(reference points seen from along a bare corridor 2 m wide, a scan at the origin)."""
    corridor = np.array([[-20.0, -1.0, 20.0, -1.0], [20.0, 1.0, -20.0, 1.0]])
    angles = np.linspace(-0.3, 0.3, 61) + math.pi / 2     # looking at the walls only
    angles = np.concatenate((angles, angles + math.pi))
    ref = np.vstack([_to_map((x, 0.0, 0.0), _points((x, 0.0, 0.0), angles, corridor))
                     for x in np.arange(-1.0, 1.01, 0.1)])
    return ref, _points((0.0, 0.0, 0.0), angles, corridor)


def test_unpenalized_match_flat_to_the_window_edge_tells_little_along_it():
    """In a corridor the unpenalized response is as high at the window's edge as at its
    centre: the window cannot show how far that goes, so the variance along the corridor
    is at least the window's side squared; across it the match stays tight. Penalized
    (the sequential match, pulled to its prediction) the window's spread is kept."""
    ref, pts = _corridor_scan()
    matcher = cm.ScanMatcher(SEARCH, SETTINGS, 12.0)
    free = matcher.match(pts, ref, np.zeros(3), penalize=False)
    assert free.covariance[0, 0] >= SEARCH.dimension ** 2
    assert free.covariance[1, 1] < 0.03 ** 2
    held = matcher.match(pts, ref, np.zeros(3), penalize=True)
    assert held.covariance[0, 0] < SEARCH.dimension ** 2


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_compiled_grid_kernels_equal_their_oracles(seed):
    """csrc/correlation_grid.c (the smeared stamp, the branch and bound's pooled grid)
    against the NumPy references, on random grids with hits at the stamp's margin."""
    rng = np.random.default_rng(seed)
    h, w = rng.integers(20, 60, size=2)
    kernel = cm.smear_kernel(0.01, rng.uniform(0.0, 0.03))
    half = kernel.shape[0] // 2
    ys, xs = rng.integers(half, h - half, 40), rng.integers(half, w - half, 40)
    hits = np.unique(ys * w + xs)
    base = rng.integers(0, 60, size=h * w).astype(np.uint8)
    fast, slow = base.copy(), base.copy()
    cm._stamp(fast, hits, kernel, int(w))
    cm._stamp_reference(slow, hits, kernel, int(w))
    assert_array_equal(fast, slow)
    values = rng.integers(0, 256, size=(h, w)).astype(np.uint8)
    for extent in (1, 3, 15, int(max(h, w)) + 2):
        assert_array_equal(cm._box_max(values, extent), cm._box_max_reference(values, extent))
    # the responses' sums, to the grid's first and last cell
    flat = values.reshape(-1)
    cells = rng.integers(5, h * w - 5, size=(7, 30))
    shift = np.array([-5, -1, 0, 2, 4])
    cells[0, 0], cells[-1, -1] = 5, h * w - 5
    assert_array_equal(cm._correlate_sums(flat, cells, shift), cm._correlate_sums_reference(flat, cells, shift))
    with pytest.raises(IndexError):
        cm._correlate_sums(flat, cells, np.array([5]))
