"""Scan matcher: the fast score equals the slow reference; a known offset is recovered."""
import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

from my_summit_mapping import scan_matcher as sm
from my_summit_mapping.grid import PatchGrid
from synthetic_world import ANGLES, ray_cast

RES = 0.047           # not a divisor of the wall coordinates (walls mid-cell, as in reality) [m]
MAX_URANGE = 20.0     # [m]
MAX_RANGE = 30.0      # [m]
LASER = np.array([0.2, 0.0, 0.0])   # laser 0.2 m ahead of the base [m, m, rad]
TRUE_POSE = np.array([0.3, -0.2, 0.1])


def _laser(base_pose):
    return sm.laser_poses(np.asarray(base_pose, float)[None, :], LASER)[0]


@pytest.fixture(scope="module")
def room_map():
    g = PatchGrid(RES)
    for pose in ([0.0, 0.0, 0.0], [0.5, 0.3, 0.4], [-0.6, 0.8, -0.5], [1.5, -1.0, 2.0]):
        lp = _laser(pose)
        g.integrate_scan(lp, ray_cast(lp), ANGLES, MAX_URANGE, MAX_RANGE)
    return g


def _beams(base_pose, lskip=0):
    lp = _laser(base_pose)
    return sm.select_beams(ray_cast(lp), ANGLES, MAX_URANGE, MAX_RANGE, lskip)


def test_select_beams_skips_and_drops_no_returns():
    r = np.array([1.0, np.nan, 2.0, 25.0, 3.0, 0.0, 4.0, np.inf])
    b = sm.select_beams(r, np.arange(8.0), 20.0, 30.0, 0)
    assert_allclose(b.ranges, [1.0, 2.0, 3.0, 4.0])
    b = sm.select_beams(r, np.arange(8.0), 20.0, 30.0, 1)   # beams 0, 2, 4, 6
    assert_allclose(b.angles, [0.0, 2.0, 4.0, 6.0])


@pytest.mark.parametrize("kernel_size", [1, 2])
def test_fast_score_matches_reference(room_map, kernel_size):
    rng = np.random.default_rng(5)
    beams = _beams(TRUE_POSE, lskip=9)
    poses = TRUE_POSE + rng.normal(scale=[0.05, 0.05, 0.03], size=(4, 3))
    pts = sm.endpoints(poses, LASER, beams.local_xy)
    fields = sm.build_fields([room_map] * 4, pts, 0.05, 0.075, kernel_size)
    fast = sm.score_poses(fields, np.arange(4), poses[:, None, :], LASER, beams.local_xy)[:, 0]
    loglik, score = sm.likelihood_and_score(fields, poses, LASER, beams)
    assert_allclose(score, fast, rtol=1e-6)
    for i, pose in enumerate(poses):
        s_ref, l_ref = sm.score_reference(room_map, pose, LASER, beams, 0.05, kernel_size, 0.075)
        assert_allclose(fast[i], s_ref, rtol=1e-4, atol=1e-4)
        assert_allclose(loglik[i], l_ref, rtol=1e-4, atol=1e-3)
    assert fast.max() > 0.5 * len(beams.ranges)    # near the truth most beams match


def test_recovers_known_offset(room_map):
    beams = _beams(TRUE_POSE)
    start = TRUE_POSE + np.array([0.15, -0.1, 0.05])
    pts = sm.endpoints(start, LASER, beams.local_xy)
    fields = sm.build_fields([room_map], pts[None], 0.05, 0.075, 1)
    pose, score = sm.optimize(fields, start[None, :], LASER, beams, 0.05, 0.05, 5)
    assert_allclose(pose[0, :2], TRUE_POSE[:2], atol=0.015)   # well within a cell
    assert_allclose(pose[0, 2], TRUE_POSE[2], atol=0.005)
    assert score[0] > 0.9 * len(beams.ranges)


def test_lockstep_optimize_equals_sequential(room_map):
    rng = np.random.default_rng(6)
    beams = _beams(TRUE_POSE, lskip=2)
    starts = TRUE_POSE + rng.normal(scale=[0.08, 0.08, 0.04], size=(5, 3))
    pts = sm.endpoints(starts, LASER, beams.local_xy)
    fields = sm.build_fields([room_map] * 5, pts, 0.05, 0.075, 1)
    poses, scores = sm.optimize(fields, starts, LASER, beams, 0.05, 0.05, 5)
    for i in range(5):
        pose, score = sm.optimize_single(fields, i, starts[i], LASER, beams, 0.05, 0.05, 5)
        assert_allclose(poses[i], pose, atol=1e-12)
        assert scores[i] == pytest.approx(score)


def test_empty_map_scores_zero():
    beams = _beams(TRUE_POSE)
    pts = sm.endpoints(TRUE_POSE, LASER, beams.local_xy)
    fields = sm.build_fields([PatchGrid(RES)], pts[None], 0.05, 0.075, 1)
    pose, score = sm.optimize(fields, TRUE_POSE[None, :], LASER, beams, 0.05, 0.05, 5)
    assert score[0] == 0.0
    assert_allclose(pose[0], TRUE_POSE)
    loglik, _ = sm.likelihood_and_score(fields, TRUE_POSE[None, :], LASER, beams)
    assert loglik[0] == pytest.approx(len(beams.ranges) * sm.NULL_LIKELIHOOD / 0.075, rel=1e-5)


@pytest.mark.parametrize("kernel_size", [1, 2])
def test_directional_score_matches_reference(room_map, kernel_size):
    """Directional fields: each beam counts only the obstacle cells reachable from known
    free space against its direction (facing_masks), as the brute-force reference does."""
    rng = np.random.default_rng(7)
    beams = _beams(TRUE_POSE, lskip=9)
    poses = TRUE_POSE + rng.normal(scale=[0.05, 0.05, 0.03], size=(4, 3))
    pts = sm.endpoints(poses, LASER, beams.local_xy)
    fields = sm.build_fields([room_map] * 4, pts, 0.05, 0.075, kernel_size, directional=True)
    octants = sm.beam_octants(poses, LASER, beams.angles)
    fast = sm.score_poses(fields, np.arange(4), poses[:, None, :], LASER, beams.local_xy, octants)[:, 0]
    loglik, score = sm.likelihood_and_score(fields, poses, LASER, beams, octants)
    assert_allclose(score, fast, rtol=1e-6)
    for i, pose in enumerate(poses):
        s_ref, l_ref = sm.score_reference(room_map, pose, LASER, beams, 0.05, kernel_size, 0.075,
                                          facing_depth=sm.FACING_DEPTH)
        assert_allclose(fast[i], s_ref, rtol=1e-4, atol=1e-4)
        assert_allclose(loglik[i], l_ref, rtol=1e-4, atol=1e-3)
    # seen from inside the room every wall faces the laser: nearly the plain score
    plain = sm.build_fields([room_map] * 4, pts, 0.05, 0.075, kernel_size)
    plain_score = sm.score_poses(plain, np.arange(4), poses[:, None, :], LASER, beams.local_xy)[:, 0]
    assert np.all(fast <= plain_score + 1e-3) and np.all(fast > 0.9 * plain_score)


def test_beam_octants():
    poses = np.array([[0.0, 0.0, 0.0], [1.0, 2.0, math.pi / 2]])
    angles = np.radians([0.0, 22.0, 23.0, 90.0, 180.0, -90.0, -44.0])
    assert sm.beam_octants(poses, np.zeros(3), angles).tolist() == [[0, 0, 1, 2, 4, 6, 7],
                                                                     [2, 2, 3, 4, 6, 0, 1]]


def _one_sided_wall():
    """A wall along x seen from the north only: rows 12.. free, rows 10-11 occupied (the
    band a noisy face leaves), rows ..9 never seen (the wall's inside and south face)."""
    g = PatchGrid(0.05)
    counts = np.zeros((2, 20, 20), np.float32)
    counts[:, 10:12] = 5.0          # hits = visits: occupied
    counts[1, 12:] = 5.0            # visits only: free
    g.add_window(0, 0, counts)
    return g


def test_facing_masks_one_sided_wall():
    hits, visits = _one_sided_wall().read_window(0, 0, 20, 20)
    occ = hits > 0.1 * visits
    masks = sm.facing_masks(occ, (visits > 0) & ~occ)
    south, north, east = masks[6], masks[2], masks[0]
    assert south[11, 5:15].all() and south[10, 5:15].all()   # from the north: the whole band
    assert not north.any()        # from the south the band's near side was never seen
    assert not east[:, 2:].any()  # along the band: never through free space


def test_unseen_face_of_a_thin_wall_does_not_match():
    """A beam from the south ending on the wall's unseen south face (row 9) is 1 cell from
    the band mapped from the north: the plain field matches it, the directional one gives
    the null likelihood, so the matcher has nothing to pull it onto."""
    g = _one_sided_wall()
    pose = np.array([[0.5, 0.1, math.pi / 2]])            # heading north, laser at the base
    beams = sm.Beams(ranges=np.array([0.375]), angles=np.array([0.0]))   # ends at y = 0.475
    pts = sm.endpoints(pose, np.zeros(3), beams.local_xy)
    plain = sm.build_fields([g], pts, 0.01, 0.075, 1)
    directional = sm.build_fields([g], pts, 0.01, 0.075, 1, directional=True)
    l_plain, s_plain = sm.likelihood_and_score(plain, pose, np.zeros(3), beams)
    l_dir, s_dir = sm.likelihood_and_score(directional, pose, np.zeros(3), beams)
    assert s_plain[0] > 0.7 and l_plain[0] > -0.05
    assert s_dir[0] == 0.0 and l_dir[0] == pytest.approx(sm.NULL_LIKELIHOOD / 0.075)
    # the same endpoint reached from the north (heading south) does match the band
    from_north = np.array([[0.5, 1.0, -math.pi / 2]])
    beams_n = sm.Beams(ranges=np.array([0.475]), angles=np.array([0.0]))  # ends at y = 0.525
    pts_n = sm.endpoints(from_north, np.zeros(3), beams_n.local_xy)
    directional_n = sm.build_fields([g], pts_n, 0.01, 0.075, 1, directional=True)
    assert sm.likelihood_and_score(directional_n, from_north, np.zeros(3), beams_n)[1][0] > 0.9
