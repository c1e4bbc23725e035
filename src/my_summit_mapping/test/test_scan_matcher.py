"""Scan matcher: the fast score equals the slow reference; a known offset is recovered."""
import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

from my_summit_mapping import scan_matcher as sm
from my_summit_mapping.grid import PatchGrid
from summit_nav_common.testing.scenes import ANGLES, ray_cast

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


def _tables(grid, n=1):
    grids = [grid] + [grid.copy() for _ in range(n - 1)]
    return sm.map_tables(grids), grids


@pytest.mark.parametrize("kernel_size", [1, 2])
def test_compiled_score_matches_reference(room_map, kernel_size):
    rng = np.random.default_rng(5)
    beams = _beams(TRUE_POSE, lskip=9)
    poses = TRUE_POSE + rng.normal(scale=[0.05, 0.05, 0.03], size=(4, 3))
    tables, _grids = _tables(room_map, 4)
    loglik, score = sm.likelihood_and_score(tables, poses, LASER, beams, 0.05, 0.075, kernel_size)
    for i, pose in enumerate(poses):
        s_ref, l_ref = sm.score_reference(room_map, pose, LASER, beams, 0.05, kernel_size, 0.075)
        assert_allclose(score[i], s_ref, rtol=1e-9, atol=1e-9)
        assert_allclose(loglik[i], l_ref, rtol=1e-9, atol=1e-9)
    assert score.max() > 0.5 * len(beams.ranges)    # near the truth most beams match


def test_mean_hit_point_hand_computed():
    """One cell hit at two points: a beam's distance is to their mean, not the cell centre."""
    res = 0.05
    g = PatchGrid(res)
    # laser at (0.01, 0.01) looking along +x; hits at x = 1.012 and 1.032 in cell (20, 0)
    g.integrate_scan(np.array([0.01, 0.01, 0.0]), np.array([1.002, 1.022]), np.zeros(2), 10.0, 30.0)
    assert g.mean_hit(20, 0) == pytest.approx((1.022, 0.01), abs=1e-6)
    # a beam from (0, 0.02) ending at (1.0, 0.02): d^2 = 0.022^2 + 0.01^2 (the cell centre
    # would be at 1.025, 0.025: d^2 = 0.025^2 + 0.005^2)
    beams = sm.Beams(ranges=np.array([1.0]), angles=np.array([0.0]))
    tables, _ = _tables(g)
    loglik, score = sm.likelihood_and_score(tables, np.array([[0.0, 0.02, 0.0]]), np.zeros(3), beams,
                                            0.05, 0.075, 1)
    d2 = 0.022 ** 2 + 0.01 ** 2
    assert score[0] == pytest.approx(math.exp(-d2 / 0.05), rel=1e-5)
    assert loglik[0] == pytest.approx(-d2 / 0.075, rel=1e-4)
    # outside the +-1 cell kernel (cell 22): no match, the null likelihood
    beams = sm.Beams(ranges=np.array([1.11]), angles=np.array([0.0]))
    loglik, score = sm.likelihood_and_score(tables, np.array([[0.0, 0.02, 0.0]]), np.zeros(3), beams,
                                            0.05, 0.075, 1)
    assert score[0] == 0.0 and loglik[0] == pytest.approx(sm.NULL_LIKELIHOOD / 0.075)


def test_recovers_known_offset(room_map):
    beams = _beams(TRUE_POSE)
    start = TRUE_POSE + np.array([0.15, -0.1, 0.05])
    tables, _ = _tables(room_map)
    pose, score = sm.optimize(tables, start[None, :], LASER, beams, 0.05, 1, 0.05, 0.05, 5)
    assert_allclose(pose[0, :2], TRUE_POSE[:2], atol=0.01)   # well within a cell
    assert_allclose(pose[0, 2], TRUE_POSE[2], atol=0.003)
    assert score[0] > 0.9 * len(beams.ranges)


def test_compiled_optimize_equals_reference(room_map):
    rng = np.random.default_rng(6)
    beams = _beams(TRUE_POSE, lskip=4)
    starts = TRUE_POSE + rng.normal(scale=[0.08, 0.08, 0.04], size=(3, 3))
    tables, _ = _tables(room_map, 3)
    poses, scores = sm.optimize(tables, starts, LASER, beams, 0.05, 1, 0.05, 0.05, 5)
    for i in range(3):
        pose, score = sm.optimize_reference(room_map, starts[i], LASER, beams, 0.05, 1, 0.05, 0.05, 5)
        assert_allclose(poses[i], pose, atol=1e-12)
        assert scores[i] == pytest.approx(score, rel=1e-12)


def test_each_particle_reads_its_own_map(room_map):
    """Particle 1's map differs (an empty one): its score is 0, particle 0's is not."""
    beams = _beams(TRUE_POSE)
    empty = PatchGrid(RES, room_map.pool)
    tables = sm.map_tables([room_map, empty])
    poses = np.array([TRUE_POSE, TRUE_POSE])
    loglik, score = sm.likelihood_and_score(tables, poses, LASER, beams, 0.05, 0.075, 1)
    assert score[0] > 0.9 * len(beams.ranges) and score[1] == 0.0
    assert loglik[1] == pytest.approx(len(beams.ranges) * sm.NULL_LIKELIHOOD / 0.075)
    with pytest.raises(ValueError, match="PatchPool"):
        sm.map_tables([room_map, PatchGrid(RES)])


def test_empty_map_scores_zero():
    beams = _beams(TRUE_POSE)
    tables, _ = _tables(PatchGrid(RES))
    pose, score = sm.optimize(tables, TRUE_POSE[None, :], LASER, beams, 0.05, 1, 0.05, 0.05, 5)
    assert score[0] == 0.0
    assert_allclose(pose[0], TRUE_POSE)
    loglik, _ = sm.likelihood_and_score(tables, TRUE_POSE[None, :], LASER, beams, 0.05, 0.075, 1)
    assert loglik[0] == pytest.approx(len(beams.ranges) * sm.NULL_LIKELIHOOD / 0.075, rel=1e-9)
