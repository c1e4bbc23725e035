"""The RBPF: resampling, weights, gating, input checks, and a short run in a synthetic room."""
import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

from my_summit_mapping import carmen, metrics, scan_matcher
from my_summit_mapping.grid import OCCUPIED, PatchGrid
from my_summit_mapping import rbpf as rbpf_module
from my_summit_mapping.rbpf import RbpfSlam, low_variance_resample, normalized_weights
from my_summit_mapping.slam_config import SlamConfig
from summit_nav_common.testing.scenes import ANGLES, ray_cast

LASER = (0.2, 0.0, 0.0)  # laser mount in the base frame [m, m, rad]


def _config(**overrides):
    params = dict(particles=8, linearUpdate=0.2, angularUpdate=0.2, maxUrange=20.0, maxRange=30.0,
                  xmin=-6.0, ymin=-5.0, xmax=6.0, ymax=5.0, delta=0.05, lskip=2)
    params.update(overrides)
    return SlamConfig.from_dict(params)


def _scan(pose):
    c, s = math.cos(pose[2]), math.sin(pose[2])
    lp = (pose[0] + c * LASER[0], pose[1] + s * LASER[0], pose[2])
    return ray_cast(lp)


@pytest.mark.parametrize("weights", [[0.5, 0.25, 0.125, 0.125], [0.7, 0.1, 0.1, 0.05, 0.05, 0.0],
                                     [0.01] * 100])
def test_low_variance_resampling_copy_counts(weights):
    w = np.array(weights) / np.sum(weights)
    n = len(w)
    rng = np.random.default_rng(7)
    total = np.zeros(n)
    for _ in range(200):
        idx = low_variance_resample(w, rng)
        assert idx.shape == (n,) and np.all(np.diff(idx) >= 0)
        counts = np.bincount(idx, minlength=n)
        # systematic resampling: each particle gets floor(N w) or ceil(N w) copies
        assert np.all(counts >= np.floor(n * w - 1e-9)) and np.all(counts <= np.ceil(n * w + 1e-9))
        total += counts
    assert_allclose(total / 200, n * w, atol=0.1)


def test_normalized_weights_and_neff():
    w, neff = normalized_weights(np.zeros(10), 3.0)
    assert_allclose(w, 0.1) and neff == pytest.approx(10.0)
    logw = np.array([-100.0, -10.0, 0.0, -1000.0])
    w, neff = normalized_weights(logw, 3.0)
    expected = np.exp((logw - logw.max()) / (3.0 * 4))   # gmapping: gain = 1/(ogain*N)
    assert_allclose(w, expected / expected.sum())
    assert w.sum() == pytest.approx(1.0) and neff == pytest.approx(1.0 / np.sum(w * w))


def _drive(slam, truth, odom, stamps=None):
    used = []
    for k, (p, o) in enumerate(zip(truth, odom)):
        if slam.process(o, _scan(p), ANGLES, LASER, None if stamps is None else stamps[k]):
            used.append(k)
    return np.array(used)


def _loop_path():
    """Reference poses (x, y, theta) around the room's middle, ~0.1 m apart."""
    t = np.linspace(0.0, 2.0 * np.pi, 120)
    x, y = 2.8 * np.cos(t), 0.4 + 2.2 * np.sin(t)
    th = np.arctan2(np.gradient(y), np.gradient(x))
    return np.column_stack((x, y, th))


def test_slam_in_synthetic_room_beats_drifting_odometry():
    truth = _loop_path()
    odom = carmen.make_drifted_odometry(truth, np.random.default_rng(8), trans_per_trans=0.1,
                                        rot_per_trans=0.1, rot_per_rot=0.1)
    slam = RbpfSlam(_config(), np.random.default_rng(9))
    used = _drive(slam, truth, odom)
    traj = slam.trajectory()
    assert len(traj) == len(used) == slam.update_count
    assert slam.trajectory_times().shape == (len(used),)
    ate_slam = metrics.ate_rmse(traj, truth[used])
    ate_odom = metrics.ate_rmse(odom[used], truth[used])
    assert ate_slam < 0.05 and ate_odom > 3 * ate_slam
    # weights stay a distribution; the map is an OccupancyGrid covering the extent
    assert slam.weights.sum() == pytest.approx(1.0) and 1.0 <= slam.neff <= 8.0
    assert 0.0 <= slam.entropy() <= math.log(8) + 1e-9
    data, width, height, res, ox, oy = slam.occupancy_grid()
    assert data.dtype == np.int8 and data.size == width * height and res == 0.05
    assert ox <= -6.0 and oy <= -5.0 and ox + width * res >= 6.0 and oy + height * res >= 5.0
    # the wall at x = +5 m appears (occupied within 0.1 m in the first pose's frame)
    grid = data.reshape(height, width)
    occ = np.argwhere(grid == OCCUPIED)
    xs = ox + (occ[:, 1] + 0.5) * res
    assert np.sum(np.abs(xs - 5.0) < 0.15) > 50
    # map->odom maps the odometry pose onto the best pose
    m2o, best, o = slam.map_to_odom(), slam.best_pose(), odom[-1]
    c, s = math.cos(m2o[2]), math.sin(m2o[2])
    assert_allclose([m2o[0] + c * o[0] - s * o[1], m2o[1] + s * o[0] + c * o[1]], best[:2], atol=1e-9)


def test_resampling_keeps_state_consistent():
    truth = _loop_path()[:40]
    odom = carmen.make_drifted_odometry(truth, np.random.default_rng(10), 0.2, 0.05, 0.2, 0.2)
    slam = RbpfSlam(_config(resampleThreshold=1.0), np.random.default_rng(11))  # resample every update
    _drive(slam, truth, odom)
    assert slam.resample_count == slam.update_count - 1
    assert_allclose(slam.weights, 1.0 / 8) and np.all(slam.log_weights == 0.0)
    assert len(slam.maps) == 8 and len({id(m) for m in slam.maps}) == 8
    # no stale copies: every pool slot in use is a patch some particle's map holds, its
    # reference count the number of maps holding it (sharing itself: test_grid). Not
    # "<= 8 x particle 0's bytes": the particles' paths differ, and on one machine another
    # particle's map reached one patch more than particle 0's.
    held = [m.patch_ids() for m in slam.maps]
    union = set().union(*held)
    pool = slam.maps[0].pool
    assert all(m.pool is pool for m in slam.maps)
    assert pool.used() == len(union)
    assert all(pool.refs[slot] == sum(slot in h for h in held) for slot in union)
    assert slam.map_memory_bytes() <= sum(m.nbytes() for m in slam.maps)


def _traced_lineage(slam, index):
    """The best map's oracle: every processed scan of particle index's ancestry ray-traced
    into a fresh grid, from the start."""
    ref = PatchGrid(slam.config.delta)
    for pose, (r, a, laser, max_range) in zip(slam._ancestry(index), slam._hist_scans):
        lp = scan_matcher.laser_poses(pose[None, :], laser)[0]   # the same float operations
        ref.integrate_scan(lp, r, a, slam.config.maxUrange, max_range)
    return ref


def test_published_map_traces_the_best_lineage_and_particle_maps_hold_end_points():
    truth = _loop_path()[:60]
    odom = carmen.make_drifted_odometry(truth, np.random.default_rng(10), 0.2, 0.05, 0.2, 0.2)
    slam = RbpfSlam(_config(resampleThreshold=1.0, ogain=0.05), np.random.default_rng(12))  # lineages merge
    _drive(slam, truth[:30], odom[:30])
    slam.best_map()                                   # traces the common past once ...
    _drive(slam, truth[30:], odom[30:])               # ... which keeps growing
    grid = slam.best_map()
    assert slam.resample_count > 0 and 0 < slam._render_upto < slam.update_count - 1
    ref = _traced_lineage(slam, slam.best_particle())
    ix0, iy0, ix1, iy1 = ref.bounds()
    assert grid.bounds() == ref.bounds()
    assert_allclose(grid.read_layers(ix0, iy0, ix1 - ix0, iy1 - iy0),
                    ref.read_layers(ix0, iy0, ix1 - ix0, iy1 - iy0), rtol=1e-5, atol=1e-4)
    # a particle's own map: hits only (every visited cell is a hit), no free cells
    hits, visits = slam.maps[0].read_window(ix0, iy0, ix1 - ix0, iy1 - iy0)
    assert visits.sum() > 0 and np.array_equal(hits, visits)


def test_gating_and_temporal_update():
    slam = RbpfSlam(_config(linearUpdate=1.0, angularUpdate=0.5, temporalUpdate=2.0),
                    np.random.default_rng(12))
    pose = np.array([0.0, 0.0, 0.0])
    assert slam.process(pose, _scan(pose), ANGLES, LASER, 0.0)          # first scan
    assert not slam.process(pose + [0.1, 0, 0], _scan(pose), ANGLES, LASER, 1.0)
    assert not slam.process(pose + [0.2, 0, 0.1], _scan(pose), ANGLES, LASER, 1.5)
    assert slam.process(pose + [0.2, 0, 0.1], _scan(pose), ANGLES, LASER, 2.5)   # > 2 s
    assert slam.process(pose + [1.3, 0, 0.1], _scan(pose), ANGLES, LASER, 2.6)   # > 1 m
    assert slam.update_count == 3


def test_scan_match_below_minimum_score_keeps_the_odometry_sample(monkeypatch):
    """gmapping's scanMatch: a matched pose whose score is not above minimumScore is not
    taken; every particle stays where the motion model put it."""
    slam = RbpfSlam(_config(minimumScore=1e9, resampleThreshold=0.0), np.random.default_rng(14))
    pose = np.array([0.0, 0.0, 0.0])
    slam.process(pose, _scan(pose), ANGLES, LASER, 0.0)
    real_optimize = rbpf_module.scan_matcher.optimize
    moved = {}

    def shifted(tables, poses, *args):
        matched, scores = real_optimize(tables, poses, *args)
        moved["before"] = poses.copy()
        return matched + [0.3, 0.0, 0.0], scores
    monkeypatch.setattr(rbpf_module.scan_matcher, "optimize", shifted)
    nxt = np.array([0.25, 0.0, 0.0])
    slam.process(nxt, _scan(nxt), ANGLES, LASER, 0.5)
    assert slam.update_count == 2
    assert_allclose(slam.poses, moved["before"])             # odometry samples, not +0.3
    slam.config.minimumScore = 0.0
    slam.process(nxt + [0.25, 0, 0], _scan(nxt + [0.25, 0, 0]), ANGLES, LASER, 1.0)
    assert np.all(slam.poses[:, 0] - moved["before"][:, 0] > 0.2)   # now the match is taken


def test_robust_input():
    slam = RbpfSlam(_config(), np.random.default_rng(13))
    assert slam.best_pose() is None and slam.occupancy_grid() is None
    pose = np.zeros(3)
    ranges = _scan(pose)
    ranges[::5] = np.nan
    ranges[1::5] = np.inf
    ranges[2::5] = 99.0
    assert slam.process(pose, ranges, ANGLES, LASER)
    assert np.all(np.isfinite(slam.poses))
    with pytest.raises(ValueError, match="beam count changed from 361 to 360"):
        slam.process(pose, ranges[:-1], ANGLES[:-1], LASER)
    with pytest.raises(ValueError, match="differ in length"):
        slam.process(pose, ranges, ANGLES[:-1], LASER)
    with pytest.raises(ValueError, match="odom_pose"):
        slam.process([0.0, np.nan, 0.0], ranges, ANGLES, LASER)


def test_default_max_range_from_scan_range_max():
    slam = RbpfSlam(_config(maxRange=None, maxUrange=30.0), np.random.default_rng(14))
    pose = np.zeros(3)
    ranges = np.full(ANGLES.shape, 10.0)
    slam.process(pose, ranges, ANGLES, LASER, range_max=10.0)   # all at range_max: no returns,
    data, *_ = slam.occupancy_grid()                             # > maxRange: skipped (registerScan)
    assert np.sum(data == OCCUPIED) == 0 and np.sum(data == 0) == 0
    slam = RbpfSlam(_config(maxRange=None, maxUrange=30.0), np.random.default_rng(14))
    slam.process(pose, np.full(ANGLES.shape, 9.0), ANGLES, LASER, range_max=10.0)
    data, *_ = slam.occupancy_grid()
    assert np.sum(data == OCCUPIED) > 0 and np.sum(data == 0) > 0
