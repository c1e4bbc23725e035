"""Scan matcher: the fast score equals the slow reference; a known offset is recovered."""
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
