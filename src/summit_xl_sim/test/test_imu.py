"""The simulated IMU (summit_xl_sim.imu, a Bosch BMI088): noise against the datasheet's
densities, the bias wander's statistics, the body's real accelerations, the integrated
heading and the covariances it reports."""
import math
import os

import numpy as np
import pytest

from summit_xl_sim.imu import DEG, GRAVITY, MICRO_G, ImuModel, ImuSpec, body_specific_force
from summit_xl_sim.sim import Simulation
from summit_xl_sim.world import World

BUILTIN = os.path.join(os.path.dirname(__file__), "..", "worlds", "course_building.yaml")
DT = 0.005   # [s] the simulator's step


def run(model, v0, v1, seconds, dt=DT, steps_per_sample=2):
    """Feed the model a velocity ramp from v0 to v1 over `seconds`; returns its samples."""
    n = int(round(seconds / dt))
    out = []
    for k in range(n):
        a = [v0[i] + (v1[i] - v0[i]) * k / n for i in range(3)]
        b = [v0[i] + (v1[i] - v0[i]) * (k + 1) / n for i in range(3)]
        model.accumulate(a, b, dt)
        if (k + 1) % steps_per_sample == 0:
            out.append(model.sample())
    return out


def quiet(**kw):
    """A BMI088 with its white noise and bias off (only the kinematics left)."""
    return ImuSpec(gyro_noise_density=0.0, gyro_bias_instability=0.0, accel_noise_density=0.0,
                   accel_bias_instability=0.0, **kw)


def test_datasheet_figures():
    s = ImuSpec()
    assert s.gyro_noise_density == pytest.approx(0.014 * math.pi / 180)   # 0.014 deg/s/sqrt(Hz)
    assert s.gyro_bias_instability == pytest.approx(2.0 * math.pi / 180 / 3600)  # 2 deg/h
    assert s.accel_noise_density == pytest.approx(175e-6 * 9.80665)      # 175 ug/sqrt(Hz)
    assert s.rate == 100.0


def test_white_noise_sd_is_density_times_sqrt_rate_and_gravity_is_plus_g():
    spec = ImuSpec()
    samples = run(ImuModel(spec, np.random.default_rng(1)), (0, 0, 0), (0, 0, 0), 200.0)
    gyro = np.array([s.angular_velocity for s in samples])
    acc = np.array([s.linear_acceleration for s in samples])
    assert len(samples) == 20000
    # At 100 Hz: 0.014 deg/s/sqrt(Hz) * 10 = 0.14 deg/s; 175 ug/sqrt(Hz) * 10 = 1.75 mg.
    np.testing.assert_allclose(gyro.std(axis=0), 0.14 * DEG, rtol=0.03)
    np.testing.assert_allclose(acc.std(axis=0), 1750 * MICRO_G, rtol=0.03)
    # the means: +g on z, 0 elsewhere, within the white noise's and the bias's spread
    acc_tol = 5 * 1750 * MICRO_G / math.sqrt(20000) + 4 * spec.accel_bias_sd()
    np.testing.assert_allclose(acc.mean(axis=0), (0.0, 0.0, GRAVITY), atol=acc_tol)
    np.testing.assert_allclose(gyro.mean(axis=0), 0.0, atol=5 * 0.14 * DEG / math.sqrt(20000) + 4 * spec.gyro_bias_sd())
    # the rate is the period's: at 50 Hz the sd is density * sqrt(50)
    at50 = run(ImuModel(spec, np.random.default_rng(2)), (0, 0, 0), (0, 0, 0), 200.0, steps_per_sample=4)
    sd50 = np.std([s.angular_velocity[2] for s in at50])
    assert sd50 == pytest.approx(spec.gyro_noise_density * math.sqrt(50), rel=0.04)


def test_bias_wanders_as_its_gauss_markov_law():
    """400 IMUs with the white noise off, so a reading is the bias: across them its sd
    stays the stationary one (1.07 x the bias instability), and its correlation after one
    correlation time is e^-1."""
    spec = ImuSpec(gyro_noise_density=0.0, accel_noise_density=0.0, rate=1.0)
    start, after = [], []
    for seed in range(400):
        m = ImuModel(spec, np.random.default_rng(seed))
        samples = run(m, (0, 0, 0), (0, 0, 0), spec.bias_tau, dt=1.0, steps_per_sample=1)
        start.append(samples[0].angular_velocity)
        after.append(samples[-1].angular_velocity)
    start, after = np.array(start), np.array(after)
    sd = 0.664 / 0.618 * 2.0 * DEG / 3600
    np.testing.assert_allclose(after.std(axis=0), sd, rtol=0.12)
    for axis in range(3):
        assert np.corrcoef(start[:, axis], after[:, axis])[0, 1] == pytest.approx(math.exp(-1.0), abs=0.1)


def test_turn_integrates_to_the_true_heading_within_the_drift():
    """A 90 deg turn at 1 rad/s then 20 s at rest (sampled at 20 Hz), 80 seeds: the IMU's
    yaw is the integral of the rates it reported, and its error against the true 90 deg
    has the spread the reported yaw variance claims."""
    spec = ImuSpec()
    errors, claimed = [], []
    for seed in range(80):
        m = ImuModel(spec, np.random.default_rng(seed))
        samples = run(m, (0, 0, 1.0), (0, 0, 1.0), math.pi / 2, dt=math.pi / 2 / 158, steps_per_sample=1)
        samples += run(m, (0, 0, 1.0), (0, 0, 0), 0.05, dt=0.05, steps_per_sample=1)   # stop
        samples += run(m, (0, 0, 0), (0, 0, 0), 20.0, dt=0.05, steps_per_sample=1)
        integral = sum(s.angular_velocity[2] for s in samples[:158]) * (math.pi / 2 / 158) \
            + sum(s.angular_velocity[2] for s in samples[158:]) * 0.05
        assert samples[-1].yaw == pytest.approx(integral, abs=1e-9)
        errors.append(samples[-1].yaw - math.pi / 2)
        claimed.append(samples[-1].orientation_variance[2])
    assert np.mean(claimed) == pytest.approx(spec.yaw_variance(20.05 + math.pi / 2), rel=0.01)
    assert np.std(errors) == pytest.approx(math.sqrt(claimed[0]), rel=0.25)
    assert abs(np.mean(errors)) < 4 * math.sqrt(claimed[0]) / math.sqrt(80)


def test_centripetal_and_tangential_acceleration_at_the_lever_arm():
    lever = (0.35, 0.05)
    m = ImuModel(quiet(mount=(lever[0], lever[1], 0.0)), np.random.default_rng(0))
    # a steady arc: 1 m/s, 0.5 rad/s: centripetal w v towards the centre (+y), -w^2 r at the arm
    s = run(m, (1.0, 0.0, 0.5), (1.0, 0.0, 0.5), 1.0)[-1]
    np.testing.assert_allclose(s.linear_acceleration, (-0.25 * lever[0], 0.5 - 0.25 * lever[1], GRAVITY), atol=1e-9)
    np.testing.assert_allclose(s.angular_velocity, (0.0, 0.0, 0.5), atol=1e-12)
    # spinning up on the spot at 5 rad/s^2: the tangential wdot x r (w still small)
    m = ImuModel(quiet(mount=(lever[0], lever[1], 0.0)), np.random.default_rng(0))
    s = run(m, (0.0, 0.0, 0.0), (0.0, 0.0, 0.01), 0.002, dt=0.001, steps_per_sample=2)[0]
    np.testing.assert_allclose(s.linear_acceleration[:2], (-5.0 * lever[1], 5.0 * lever[0]), atol=1e-3)
    # braking straight at 2.5 m/s^2
    s = run(m, (1.0, 0.0, 0.0), (0.0, 0.0, 0.0), 0.4)[3]
    np.testing.assert_allclose(s.linear_acceleration, (-2.5, 0.0, GRAVITY), atol=1e-9)
    # the same braking seen by an IMU turned 90 deg left on its mount: along its -y... +y
    m90 = ImuModel(quiet(mount=(0.0, 0.0, math.pi / 2)), np.random.default_rng(0))
    s = run(m90, (1.0, 0.0, 0.0), (0.0, 0.0, 0.0), 0.4)[3]
    np.testing.assert_allclose(s.linear_acceleration, (0.0, 2.5, GRAVITY), atol=1e-9)


def test_body_specific_force_matches_the_lever_arm_points_world_velocity():
    """Oracle: the world velocity of the lever-arm point, R(yaw) (v + w x r), before and
    after one step of the simulator's kinematics (v1 held through the step), differenced
    and rotated into the body frame at the step's start."""
    v0, v1, dt, lever = (0.8, 0.1, 0.4), (0.81, 0.09, 0.43), 1e-4, (0.2, -0.1)

    def world_velocity(yaw, v):
        px, py = v[0] - v[2] * lever[1], v[1] + v[2] * lever[0]
        return math.cos(yaw) * px - math.sin(yaw) * py, math.sin(yaw) * px + math.cos(yaw) * py

    before, after = world_velocity(0.0, v0), world_velocity(v1[2] * dt, v1)
    ax, ay = (after[0] - before[0]) / dt, (after[1] - before[1]) / dt
    fx, fy, fz = body_specific_force(v0, v1, dt, lever)
    assert fx == pytest.approx(ax, abs=1e-4)
    assert fy == pytest.approx(ay, abs=1e-4)
    assert fz == GRAVITY


def test_reported_covariances():
    spec = ImuSpec()
    s = run(ImuModel(spec, np.random.default_rng(3)), (0, 0, 0), (0, 0, 0), 1.0)
    last = s[-1]
    assert last.angular_velocity_variance == pytest.approx((0.14 * DEG) ** 2 + spec.gyro_bias_sd() ** 2)
    assert last.linear_acceleration_variance == pytest.approx((1750 * MICRO_G) ** 2 + spec.accel_bias_sd() ** 2)
    assert last.orientation_variance[0] == pytest.approx((1750 * MICRO_G / GRAVITY) ** 2)
    assert s[0].orientation_variance[2] < s[50].orientation_variance[2] < last.orientation_variance[2]
    assert abs(last.roll) < 5 * math.sqrt(last.orientation_variance[0])


def test_bad_figures_are_named():
    with pytest.raises(ValueError, match="imu rate must be > 0"):
        ImuModel(ImuSpec(rate=0.0), np.random.default_rng(0))
    with pytest.raises(ValueError, match="imu gyro_noise_density must be >= 0"):
        ImuModel(ImuSpec(gyro_noise_density=float("nan")), np.random.default_rng(0))


def test_simulation_imu_follows_the_truth_and_leaves_the_other_draws_alone():
    runs = []
    for imu in (None, ImuSpec(mount=(0.1, 0.05, 0.0))):
        sim = Simulation(World.from_yaml(BUILTIN), seed=9)
        s = sim.add_robot("r", 2.0, 7.0, 0.0, imu=imu)
        samples = []
        for k in range(600):
            sim.command("r", 0.8, 0.0, 0.6)
            sim.step(DT)
            if imu is not None and k % 2 == 1:
                samples.append(s.imu.sample())
        runs.append((s.odom_pose, s.pose, sim.scan("r")))
        if imu is not None:
            true_turn = s.pose[2] - 0.0
            assert samples[-1].yaw == pytest.approx(true_turn, abs=4 * math.sqrt(samples[-1].orientation_variance[2]))
            # steady arc at the end: centripetal ~ w v at the centre, less w^2 r_y at the arm
            assert samples[-1].linear_acceleration[1] == pytest.approx(0.6 * 0.8 - 0.36 * 0.05, abs=0.1)
    assert runs[0][0] == runs[1][0] and runs[0][1] == runs[1][1]
    np.testing.assert_array_equal(runs[0][2], runs[1][2])


def test_imu_mount_comes_from_the_urdf():
    from summit_xl_sim.description import DescriptionError, fixed_joints, imu_mount
    urdf = os.path.join(os.path.dirname(__file__), "..", "urdf", "summit_xl.urdf")
    with open(urdf) as f:
        joints = fixed_joints(f.read(), urdf)
    assert imu_mount(joints) == pytest.approx((0.10, 0.05, 0.0))
    with pytest.raises(DescriptionError, match="no chain of fixed joints from 'base_footprint' to 'imu_link'"):
        imu_mount([j for j in joints if j[1] != "imu_link"])
    tilted = [(p, c, xyz, (0.3, 0.0, 0.0) if c == "imu_link" else rpy) for p, c, xyz, rpy in joints]
    with pytest.raises(DescriptionError, match="'imu_link' is not mounted level"):
        imu_mount(tilted)
