"""The online trajectory from map -> odom broadcasts, its ATE, and the update counts."""
import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

from my_summit_mapping import carmen, online_eval


def _inverse(p):
    c, s = math.cos(p[2]), math.sin(p[2])
    return np.array([-c * p[0] - s * p[1], s * p[0] - c * p[1], -p[2]])


def test_compose_matches_chaining_increments():
    a, b = np.array([1.0, 2.0, 0.5]), np.array([0.3, -0.2, 0.4])
    assert_allclose(online_eval.compose(a, b)[0], carmen.chain_increments(a, b[None, :])[1])
    assert_allclose(online_eval.compose(a, _inverse(a))[0], [0, 0, 0], atol=1e-12)


def test_map_to_odom_in_effect_is_the_last_broadcast_before_the_next_scan():
    scans = np.array([10.0, 12.0, 14.0])
    tf_t = np.array([9.0, 10.05, 11.0, 12.0, 13.9, 15.0])
    tf_v = np.arange(18, dtype=float).reshape(6, 3)
    got = online_eval.map_to_odom_at_scans(scans, tf_t, tf_v)
    # scan 0: before 12.0 -> the one at 11.0; scan 1: before 14.0 -> 13.9 (12.0 exactly
    # is already the next scan's time); the last scan: the last broadcast
    assert_allclose(got, tf_v[[2, 4, 5]])
    # nothing broadcast before the next scan: the identity, as gmapping's map -> odom
    assert_allclose(online_eval.map_to_odom_at_scans(scans, [13.0], [[1, 2, 3]]),
                    [[0, 0, 0], [1, 2, 3], [1, 2, 3]])


def test_online_ate_is_zero_when_map_to_odom_undoes_the_drift_up_to_a_rigid_motion():
    t = np.linspace(0, 2 * np.pi, 40, endpoint=False)
    ref = np.column_stack((3 * np.cos(t), 2 * np.sin(t), t))
    odom = carmen.make_drifted_odometry(ref, np.random.default_rng(3), 0.1, 0.05, 0.1, 0.1)
    frame = np.array([5.0, -1.0, 0.7])           # the SLAM map frame is anywhere
    stamps = np.arange(40.0)
    # one broadcast per scan, half a second after it: map -> odom = frame * ref * odom^-1
    m2o = np.vstack([online_eval.compose(online_eval.compose(frame, ref[k]), _inverse(odom[k]))
                     for k in range(40)])
    ate, traj = online_eval.online_ate(stamps, odom, ref, stamps + 0.5, m2o)
    assert ate == pytest.approx(0.0, abs=1e-9)
    assert_allclose(traj, online_eval.compose(np.tile(frame, (40, 1)), ref), atol=1e-9)
    # broadcast late (after the next scan): each scan gets the previous correction
    late, _ = online_eval.online_ate(stamps, odom, ref, stamps + 1.5, m2o)
    assert late > 0.01


def test_online_ate_of_a_known_error():
    # four poses on a circle, each estimate 0.1 m further out: no rotation or translation
    # removes a scale error, so the aligned RMSE is exactly 0.1 m
    ang = np.array([0, 0.5, 1.0, 1.5]) * np.pi
    ref = np.column_stack((np.cos(ang), np.sin(ang), ang))
    est = np.column_stack((1.1 * np.cos(ang), 1.1 * np.sin(ang), ang))
    odom = est.copy()                             # map -> odom stays the identity
    ate, traj = online_eval.online_ate(np.arange(4.0), odom, ref, [], np.zeros((0, 3)))
    assert ate == pytest.approx(0.1, abs=1e-12)
    assert_allclose(traj[:, :2], est[:, :2], atol=1e-12)


def test_count_updates_counts_changes_plus_the_first_scan():
    assert online_eval.count_updates(np.zeros((0, 3))) == 0
    same = np.zeros((5, 3))
    assert online_eval.count_updates(same) == 1            # initialized, never updated again
    v = np.array([[0, 0, 0], [0, 0, 0], [0.1, 0, 0], [0.1, 0, 0], [0.1, 0, 0.01], [0.2, 0, 0.01]])
    assert online_eval.count_updates(v) == 4


def test_expected_updates_follow_linear_and_angular_thresholds():
    # 0.15 m steps: every second one crosses 0.2 m; then 0.06 rad turns in place: every second
    steps = [[0.15 * k, 0, 0] for k in range(5)]
    turns = [[0.6, 0, 0.06 * k] for k in range(1, 5)]
    odom = np.array(steps + turns, float)
    assert online_eval.expected_updates(odom, 0.2, 0.1) == 1 + 2 + 2
    assert online_eval.expected_updates(odom[:1], 0.2, 0.1) == 1
    assert online_eval.expected_updates(np.zeros((0, 3)), 0.2, 0.1) == 0
    assert online_eval.expected_updates(odom, 0.0, 0.0) == len(odom)


def _ellipse(n=40):
    t = np.linspace(0, 2 * np.pi, n, endpoint=False)
    return np.column_stack((3 * np.cos(t), 2 * np.sin(t), t + np.pi / 2))


def test_error_series_is_zero_up_to_a_rigid_motion_and_finds_a_heading_offset():
    ref = _ellipse()
    moved = online_eval.compose(np.tile([5.0, -1.0, 0.7], (len(ref), 1)), ref)
    err, heading = online_eval.error_series(moved, ref)
    assert_allclose(err, 0.0, atol=1e-9)
    assert_allclose(heading, 0.0, atol=1e-9)
    turned = moved + [0.0, 0.0, 0.1]              # positions right, every heading 0.1 rad off
    assert_allclose(online_eval.error_series(turned, ref)[1], 0.1, atol=1e-9)


def test_error_series_rms_is_the_ate():
    ref = _ellipse()
    est = ref + np.random.default_rng(4).normal(0.0, 0.1, ref.shape)
    err, _ = online_eval.error_series(est, ref)
    assert float(np.sqrt(np.mean(np.sum(err ** 2, axis=1)))) == pytest.approx(
        online_eval.metrics.ate_rmse(est, ref), rel=1e-12)


def test_step_errors_find_one_long_step_in_any_frame():
    # a straight run north; the estimate's step 3 is 0.3 m too long, the rest exact
    ref = np.column_stack((np.zeros(8), 0.5 * np.arange(8), np.full(8, np.pi / 2)))
    est = ref.copy()
    est[4:, 1] += 0.3
    est = online_eval.compose(np.tile([2.0, 1.0, -0.4], (8, 1)), est)  # the estimate's own frame
    steps = online_eval.step_errors(est, ref)
    want = np.zeros((7, 3))
    want[3, 0] = 0.3                               # along track
    assert_allclose(steps, want, atol=1e-9)
    assert online_eval.step_errors(ref[:1], ref[:1]).shape == (0, 3)


def test_update_delays_after_the_latest_scan():
    scans = np.array([10.0, 12.0, 14.0])
    tf_t = np.array([9.0, 9.5, 10.3, 10.35, 12.5, 14.2, 14.25])
    tf_v = np.array([[0, 0, 0], [0.1, 0, 0],      # 9.5: a change before the first scan: left out
                     [0.2, 0, 0], [0.2, 0, 0],    # 10.3: 0.3 s after scan 0; 10.35 the same value
                     [0.2, 0.1, 0], [0.2, 0.1, 0.05], [0.3, 0.1, 0.05]], float)
    delays, per_scan = online_eval.update_delays(scans, tf_t, tf_v)
    assert_allclose(delays, [0.3, 0.5, 0.2, 0.25])
    assert per_scan.tolist() == [1, 1, 2]
