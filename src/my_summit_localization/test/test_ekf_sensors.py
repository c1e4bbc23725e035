"""Sensor messages -> measurements (differential, relative, IMU mounting, gravity), the
parameter reader's defaults and errors, and the runner's handling of bad messages."""
import collections
import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

from my_summit_localization import ekf_config, ekf_runner, ekf_sensors
from my_summit_localization.ekf import STATE_SIZE, VX, VY, VYAW, X, YAW, predict_state
from my_summit_localization.ekf_config import ConfigError, read_config
from my_summit_localization.ekf_sensors import SensorState
from summit_nav_common.geometry import euler_from_matrix, quaternion_from_euler

T, F = True, False
POSE_XY_YAW = [T, T, F, F, F, T] + [F] * 9
TWIST_VX_VY_VYAW = [F] * 6 + [T, T, F, F, F, T] + [F] * 3
YAW_RATE = [F] * 11 + [T] + [F] * 3


def sensor(config, **kw):
    return SensorState("odom0", "/odom", np.array(config, dtype=bool), **kw)


def cov6(v=0.01):
    return np.eye(6) * v


# ----- measurements ------------------------------------------------------------------

def test_differential_pose_becomes_body_velocity():
    """Poses (1, 2, yaw 90 deg) then (1, 2.1, yaw 95 deg) 0.1 s later: the robot moved 0.1 m
    along its own x, so vx = 1 m/s, vy = 0, vyaw = 5 deg / 0.1 s; covariance (prev + cur) dt."""
    s = sensor(POSE_XY_YAW, differential=True)
    assert ekf_sensors.pose_measurement(s, 0.0, [1, 2, 0, 0, 0, math.pi / 2], cov6()) is None
    m = ekf_sensors.pose_measurement(s, 0.1, [1, 2.1, 0, 0, 0, math.radians(95)], cov6())
    assert list(np.flatnonzero(m.mask)) == [VX, VY, VYAW]
    assert_allclose(m.z[[VX, VY, VYAW]], [1.0, 0.0, math.radians(50)], atol=1e-9)
    assert m.cov[VX, VX] == pytest.approx((0.01 + 0.01) * 0.1)


def test_relative_pose_starts_at_zero():
    """relative: the first pose is the origin; a later one is seen from it."""
    s = sensor(POSE_XY_YAW, relative=True)
    m0 = ekf_sensors.pose_measurement(s, 0.0, [5, 5, 0, 0, 0, math.pi / 2], cov6())
    assert_allclose(m0.z[[X, 1, YAW]], 0.0, atol=1e-12)
    m1 = ekf_sensors.pose_measurement(s, 1.0, [5, 6, 0, 0, 0, math.pi / 2], cov6())
    assert_allclose(m1.z[[X, 1, YAW]], [1.0, 0.0, 0.0], atol=1e-12)


def test_imu_rotated_into_base_frame():
    """An IMU mounted upside down (180 deg about x): its yaw rate +0.3 is the base's -0.3;
    its orientation yaw 0.2 is the base's -0.2; angular velocity variance carried over."""
    s = SensorState("imu0", "/imu/data", np.array([F, F, F, F, F, T] + [F] * 5 + [T] + [F] * 3))
    flip = np.diag([1.0, -1.0, -1.0])
    q_yaw = [0.0, 0.0, math.sin(0.1), math.cos(0.1)]       # imu frame yawed 0.2 in the world
    # world <- imu = Rz(0.2); base = imu flipped: world <- base = Rz(0.2) flip^T
    out = ekf_sensors.imu_measurements(s, 1.0, q_yaw, np.eye(3) * 1e-4, [0, 0, 0.3], np.eye(3) * 2e-5,
                                       [0, 0, 9.8], np.eye(3) * 1e-2, base_from_imu=flip)
    assert len(out) == 2
    ori, rate = out
    r = ekf_sensors.rotation(*ori.z[3:6])
    assert_allclose(r, ekf_sensors.rotation(0, 0, 0.2) @ flip.T, atol=1e-12)
    assert rate.z[VYAW] == pytest.approx(-0.3)
    assert rate.cov[VYAW, VYAW] == pytest.approx(2e-5)


def test_imu_parts_not_provided_are_left_out():
    """sensor_msgs/Imu: covariance[0] = -1 means not provided; a zero quaternion is no
    orientation."""
    s = SensorState("imu0", "/imu/data", np.array([F, F, F, F, F, T] + [F] * 5 + [T] + [F] * 3))
    out = ekf_sensors.imu_measurements(s, 1.0, [0, 0, 0, 1], -np.eye(3), [0, 0, 0.3], np.eye(3),
                                       [0, 0, 0], -np.eye(3))
    assert len(out) == 1 and out[0].mask[VYAW]
    out = ekf_sensors.imu_measurements(s, 1.0, [0, 0, 0, 0], np.eye(3), [0, 0, 0.3], -np.eye(3), [0, 0, 0], np.eye(3))
    assert out == []


def test_imu_gravity_removed():
    """A level IMU at rest reads +g on z; with remove_gravitational_acceleration the
    fused acceleration is 0; tilted by 90 deg about y, gravity shows on its -x... and is
    removed there too."""
    cfg = np.array([F] * 12 + [T, T, T])
    s = SensorState("imu0", "/imu/data", cfg, remove_gravitational_acceleration=True)
    m, = ekf_sensors.imu_measurements(s, 0.0, [0, 0, 0, 1], np.eye(3), [0, 0, 0], np.eye(3),
                                      [0.5, 0, 9.80665], np.eye(3))
    assert_allclose(m.z[12:15], [0.5, 0, 0], atol=1e-9)
    q = [0, math.sin(math.pi / 4), 0, math.cos(math.pi / 4)]     # pitched 90 deg
    m, = ekf_sensors.imu_measurements(s, 0.0, q, np.eye(3), [0, 0, 0], np.eye(3), [-9.80665, 0, 0], np.eye(3))
    assert_allclose(m.z[12:15], 0.0, atol=1e-9)


# ----- parameters --------------------------------------------------------------------

def test_defaults_are_robot_localizations():
    c = read_config({})
    assert c.frequency == 30.0 and c.sensor_timeout == pytest.approx(1 / 30)
    assert (c.map_frame, c.odom_frame, c.base_link_frame, c.world_frame) == ("map", "odom", "base_link", "odom")
    assert c.publish_tf and not c.two_d_mode
    assert c.process_noise_covariance[5, 5] == 0.06 and c.process_noise_covariance[0, 1] == 0.0
    assert_allclose(np.diagonal(c.initial_estimate_covariance), 1e-9)
    assert any("no sensor" in w for w in c.warnings)


def test_sensors_read_with_their_options():
    c = read_config({"odom0": "/odom", "odom0_config": TWIST_VX_VY_VYAW, "odom0_twist_rejection_threshold": 5,
                     "imu0": "imu/data", "imu0_config": YAW_RATE, "imu0_differential": False,
                     "imu0_queue_size": 10, "imu0_angular_velocity_rejection_threshold": 0.8,
                     "imu0_remove_gravitational_acceleration": True, "frequency": 50, "two_d_mode": True})
    assert [(s.kind, s.topic, s.queue_size) for s in c.sensors] == [("odom", "/odom", 1), ("imu", "imu/data", 10)]
    odom, imu = (s.state for s in c.sensors)
    assert odom.twist_threshold == 5.0 and odom.pose_threshold == math.inf
    assert imu.angular_velocity_threshold == 0.8 and imu.remove_gravitational_acceleration
    assert c.sensor_timeout == pytest.approx(0.02)


@pytest.mark.parametrize("params, names", [
    ({"odom0": "/odom", "odom0_config": [True] * 14}, "odom0_config"),
    ({"odom0": "/odom", "odom0_config": [1, 0] * 7 + [1]}, "odom0_config"),
    ({"odom0": "/odom", "odom0_config": "true"}, "odom0_config"),
    ({"world_frame": "earth"}, "world_frame"),
    ({"odom_frame": "base_link"}, "base_link_frame"),
    ({"base_link_frame": ""}, "base_link_frame"),
    ({"frequency": 0}, "frequency"),
    ({"two_d_mode": "yes"}, "two_d_mode"),
    ({"process_noise_covariance": [0.1] * 15}, "process_noise_covariance"),
    ({"initial_estimate_covariance": list(-np.eye(15).ravel())}, "initial_estimate_covariance"),
    ({"odom0": "/odom", "odom0_queue_size": 0}, "odom0_queue_size"),
    ({"odom0": "/odom", "odom0_angular_velocity_rejection_threshold": 1.0}, "odom0_angular_velocity"),
    ({"imu0": "/imu", "imu0_pose_rejection_threshold": -1}, "imu0_pose_rejection_threshold"),
    ({"use_control": True}, "use_control"),
    ({"smooth_lagged_data": True, "history_length": -1.0}, "history_length"),
])
def test_bad_parameters_named(params, names):
    with pytest.raises(ConfigError, match=names):
        read_config(params)


def test_unread_names_include_misspelt_sensor_options():
    params = {"odom0": "/odom", "odom0_confg": TWIST_VX_VY_VYAW}
    assert "odom0_confg" not in ekf_config.known_names(params)
    assert "odom0_config" in ekf_config.known_names(params)


# ----- the runner ----------------------------------------------------------------------

def runner(**params):
    params = {"odom0": "/odom", "odom0_config": TWIST_VX_VY_VYAW, "two_d_mode": True, "frequency": 10,
              **params}
    c = read_config(params)
    return ekf_runner.EkfRunner(c, [s.topic for s in c.sensors]), c.sensors[0].state


def twist_msg(s, stamp, vx=1.0, vyaw=0.0, var=1e-3):
    return ekf_sensors.twist_measurement(s, stamp, [vx, 0, 0, 0, 0, vyaw], np.eye(6) * var)


def test_nan_message_dropped_whole():
    r, s = runner()
    assert r.add("/odom", 0.0, [twist_msg(s, 0.0)], now=0.0) is None
    why = r.add("/odom", 0.1, [twist_msg(s, 0.1, vx=math.nan)], now=0.1)
    assert "vx is NaN" in why
    why = r.add("/odom", 0.1, [twist_msg(s, 0.1, var=math.nan)], now=0.1)
    assert "covariance of vx" in why
    r.update(0.2)
    assert np.all(np.isfinite(r.ekf.x)) and r.ekf.x[VX] == pytest.approx(1.0)
    assert r.counts["/odom"]["dropped"] == 2


def test_out_of_order_and_future_stamps_dropped():
    r, s = runner()
    assert r.add("/odom", 1.0, [twist_msg(s, 1.0)], now=1.0) is None
    assert "out of order" in r.add("/odom", 0.9, [twist_msg(s, 0.9)], now=1.0)
    assert "future" in r.add("/odom", 5.0, [twist_msg(s, 5.0)], now=1.0)
    # a little ahead: waits for its time
    assert r.add("/odom", 1.2, [twist_msg(s, 1.2, vx=2.0)], now=1.0) is None
    r.update(1.1)
    assert r.ekf.time == 1.0 and len(r.queue) == 1
    r.update(1.2)
    assert r.ekf.time == 1.2 and r.ekf.x[VX] > 1.0


def test_measurements_fused_in_stamp_order_and_timeout_predicts():
    """Two topics queued out of arrival order are fused by stamp; with nothing for
    sensor_timeout the filter predicts to now."""
    r, s = runner(imu0="/imu", imu0_config=YAW_RATE)
    imu = SensorState("imu0", "/imu", np.array(YAW_RATE))
    r.add("/odom", 0.2, [twist_msg(s, 0.2)], now=0.2)
    r.add("/imu", 0.1, ekf_sensors.imu_measurements(imu, 0.1, [0, 0, 0, 1], -np.eye(3), [0, 0, 0.5],
                                                    np.eye(3) * 1e-4, [0, 0, 0], -np.eye(3)), now=0.2)
    r.update(0.2)
    assert r.ekf.time == 0.2 and r.counts["/imu"]["fused"] == 1 and r.counts["/odom"]["fused"] == 1
    x = r.ekf.x.copy()
    r.update(1.0)    # sensor_timeout 0.1 s: the output predicted, the filter kept
    out_x, _, out_t = r.state()
    assert out_t == 1.0 and r.ekf.time == 0.2
    assert_allclose(out_x, predict_state(x, 0.8), atol=1e-12)
    assert_allclose(r.ekf.x, x)


def test_late_measurements_after_timeout_fused_in_order():
    """The filter output predicted through a gap with a stale turn rate; the gap's
    measurements, arriving late, are then fused in stamp order from the filter's last
    measurement, so the turn they saw is in the heading (a busy machine delayed them)."""
    r, s = runner(sensor_timeout=0.1)
    r.add("/odom", 0.0, [twist_msg(s, 0.0, vyaw=0.0)], now=0.0)
    r.update(0.0)
    r.update(1.0)          # nothing for 1 s: output predicted with vyaw 0
    assert r.state()[0][YAW] == pytest.approx(0.0, abs=1e-9)
    for k in range(1, 11):  # the gap's messages: turning at 1 rad/s
        t = 0.1 * k
        r.add("/odom", t, [twist_msg(s, t, vyaw=1.0, var=1e-6)], now=1.0)
    r.update(1.0)
    x, _, t = r.state()
    assert t == pytest.approx(1.0)
    assert x[YAW] == pytest.approx(0.9, abs=0.06)   # ~ the turn from 0.1 s to 1 s


def imu_rate(imu, stamp, vyaw, var=1e-4):
    return ekf_sensors.imu_measurements(imu, stamp, [0, 0, 0, 1], -np.eye(3), [0, 0, vyaw], np.eye(3) * var,
                                        [0, 0, 0], -np.eye(3))


def lagged_tour(lag, **params):
    """A gyro (100 Hz, on time) and wheel odometry (50 Hz, arriving `lag` [s] after its
    stamp) while the robot drives straight for 1 s and then turns at 1 rad/s for 1 s; a
    runner updated at 50 Hz. Returns the runner after the last update."""
    r, odom = runner(imu0="/imu", imu0_config=YAW_RATE, frequency=50, **params)
    imu = r.config.sensors[1].state
    arrivals = []
    for k in range(201):
        t = 0.01 * k
        w = 1.0 if t >= 1.0 else 0.0
        arrivals.append((t, "/imu", t, imu_rate(imu, t, w)))
        if k % 2 == 0:   # the wheels' yaw rate: exact, and trusted more than the gyro
            arrivals.append((t + lag, "/odom", t, [twist_msg(odom, t, vx=1.0, vyaw=w, var=1e-6)]))
    arrivals.sort(key=lambda a: a[0])
    i = 0
    for k in range(int(round((2.0 + lag) / 0.02)) + 2):
        now = 0.02 * k
        while i < len(arrivals) and arrivals[i][0] <= now + 1e-12:
            _, topic, stamp, ms = arrivals[i]
            assert r.add(topic, stamp, ms, now) is None
            i += 1
        r.update(now)
    return r


def test_smooth_lagged_data_fuses_as_in_stamp_order():
    """Regression (issue 41): the benchmark's recorded /odom reaches the node up to
    0.14 s after its stamp, behind the IMU's messages, and our node (as
    robot_localization without smooth_lagged_data) corrected each such lagged
    measurement against a state already moved on, unpredicted: at a turn's start the
    wheels' stale "not turning" pulled the yaw rate back, and on the tour the fused ATE
    was 0.09 m where stamp order gives 0.017 m. With smooth_lagged_data the filter goes
    back to its state before the lagged measurement and fuses everything since again, in
    stamp order: the result is that of in-order arrival; without it, it is not."""
    on_time = lagged_tour(0.0)
    assert on_time.lagged == 0 and on_time.reverts == 0
    assert on_time.ekf.x[YAW] == pytest.approx(1.0, abs=0.02)     # 1 s at 1 rad/s
    late = lagged_tour(0.1)
    assert late.lagged > 0
    assert abs(late.ekf.x[YAW] - on_time.ekf.x[YAW]) > 0.02       # the lag cost heading
    smoothed = lagged_tour(0.1, smooth_lagged_data=True, history_length=0.5)
    assert smoothed.reverts > 0 and smoothed.lagged == 0
    assert smoothed.ekf.time == on_time.ekf.time
    assert_allclose(smoothed.ekf.x, on_time.ekf.x, atol=1e-9)
    assert_allclose(smoothed.ekf.P, on_time.ekf.P, atol=1e-12)
    # each message counted once, however often it was fused again
    assert smoothed.counts["/odom"]["fused"] == 101 and smoothed.counts["/imu"]["fused"] == 201


def test_smooth_lagged_data_history_too_short():
    """A measurement older than the history kept (history_length) is fused as without
    smoothing (corrected where the filter is) and counted as lagged; the history stays
    within history_length of the filter's time."""
    r = lagged_tour(0.1, smooth_lagged_data=True, history_length=0.05)
    assert r.lagged > 0
    assert all(h[0] >= r.ekf.time - 0.05 for h in r.history)
    assert np.all(np.isfinite(r.ekf.x))


def test_silent_topic_named_once():
    r, s = runner(imu0="/imu", imu0_config=YAW_RATE, frequency=10)
    r.update(0.0)
    for k in range(1, 80):
        t = k * 0.1
        r.add("/odom", t, [twist_msg(s, t)], now=t)
        r.update(t)
        silent = r.silent_topics(t)
        if t < ekf_runner.SILENT_AFTER:
            assert silent == []
        elif t < ekf_runner.SILENT_AFTER + 0.1:
            assert silent == ["/imu"]
        else:
            assert silent == []
    assert r.ekf.x[X] > 6.0     # the filter ran on /odom alone


def test_set_pose_resets_state_and_references():
    r, s = runner()
    s.first_pose = np.eye(4)
    r.add("/odom", 1.0, [twist_msg(s, 1.0)], now=1.0)
    r.set_pose(2.0, [1.0, 2.0, 0, 0, 0, 0.5], np.eye(6) * 0.0, sensors=[s])
    assert r.ekf.time == 2.0 and r.queue == [] and r.history == collections.deque() and s.first_pose is None
    assert_allclose(r.ekf.x[[X, 1, YAW, VX]], [1.0, 2.0, 0.5, 0.0])
    assert r.ekf.P[X, X] > 0
    assert STATE_SIZE == len(r.ekf.x)


def test_quaternion_round_trip():
    rng = np.random.default_rng(1)
    for rpy in rng.uniform(-1.2, 1.2, (20, 3)):
        r = ekf_sensors.matrix_from_quaternion(quaternion_from_euler(*rpy))
        assert_allclose(r, ekf_sensors.rotation(*rpy), atol=1e-12)
        assert_allclose(euler_from_matrix(r), rpy, atol=1e-12)


# ----- odometry error --------------------------------------------------------------------

def test_odom_error_no_alignment():
    """Truth starting at (2, 7, 90 deg) driving 1 m/s along its heading; an estimate in the
    odom frame that is perfect gives 0; one with a constant 0.1 rad heading error drifts
    sideways: its final heading error is 0.1 and its ATE the RMS of the offset."""
    from my_summit_localization.odom_error import odom_error
    t = np.linspace(0.0, 10.0, 101)
    truth = np.column_stack([t, np.full_like(t, 2.0), 7.0 + t, np.full_like(t, math.pi / 2)])
    perfect = np.column_stack([t, t, np.zeros_like(t), np.zeros_like(t)])
    e = odom_error(perfect, truth)
    assert e.ate == pytest.approx(0.0, abs=1e-12) and e.final_heading == pytest.approx(0.0, abs=1e-12)
    bad = np.column_stack([t, t * math.cos(0.1), t * math.sin(0.1), np.full_like(t, 0.1)])
    e = odom_error(bad, truth)
    offsets = 2 * t * math.sin(0.05)
    assert e.final_heading == pytest.approx(0.1)
    assert e.ate == pytest.approx(math.sqrt(np.mean(offsets ** 2)))
    assert e.final_position == pytest.approx(offsets[-1])
