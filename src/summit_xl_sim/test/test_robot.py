"""Kinematics (diff and omni), acceleration limits, watchdog, command checks, odometry."""
import math

import numpy as np
import pytest

from summit_nav_common import geometry
from summit_xl_sim import robot as rb
from summit_nav_common.testing import scenes
from summit_xl_sim.sim import Simulation
from summit_xl_sim.world import World


def open_world(size_m=20.0, res=0.05):
    """The simulator's world of scenes.square_room: walls on the border only."""
    return World(scenes.square_room(size_m, res))


def quiet_params():
    return rb.RobotParams(odom_trans_noise=0.0, odom_rot_noise=0.0, odom_rot_per_trans=0.0)


def run(sim, name, cmd, seconds, dt=0.005, hold=True):
    for _ in range(int(round(seconds / dt))):
        if hold:
            sim.command(name, *cmd)
        sim.step(dt)


def test_diff_ignores_lateral_and_ramps_with_acceleration():
    sim = Simulation(open_world())
    s = sim.add_robot("r", 10.0, 10.0, 0.0, drive="diff", params=quiet_params())
    run(sim, "r", (0.5, 0.5, 0.0), 0.1)
    assert s.vel[0] == pytest.approx(min(0.5, 2.5 * 0.1))  # acc_lim_x 2.5 m/s^2
    assert s.vel[1] == 0.0
    run(sim, "r", (0.5, 0.5, 0.0), 1.9)
    # 2 s at 0.5 m/s minus the 0.2 s ramp's lost 0.05 m
    assert s.pose[0] == pytest.approx(10.0 + 0.5 * 2.0 - 0.05, abs=2e-3)
    assert s.pose[1] == pytest.approx(10.0, abs=1e-9)


def test_omni_moves_sideways():
    sim = Simulation(open_world())
    s = sim.add_robot("r", 10.0, 10.0, math.pi / 2, drive="omni", params=quiet_params())
    run(sim, "r", (0.0, 0.4, 0.0), 2.0)
    # body +y with the robot facing +y is world -x
    assert s.pose[0] == pytest.approx(10.0 - (0.4 * 2.0 - 0.4 ** 2 / (2 * 2.5)), abs=2e-3)
    assert s.pose[1] == pytest.approx(10.0, abs=1e-6)


def test_turning_integrates_an_arc():
    sim = Simulation(open_world())
    s = sim.add_robot("r", 10.0, 10.0, 0.0, params=quiet_params())
    s.vel = (0.5, 0.0, 0.5)  # start at speed, no ramp
    run(sim, "r", (0.5, 0.0, 0.5), 4 * math.pi)  # one full circle of radius 1
    assert s.pose[0] == pytest.approx(10.0, abs=1e-3)
    assert s.pose[1] == pytest.approx(10.0, abs=1e-3)


def test_watchdog_stops_after_quarter_second():
    sim = Simulation(open_world())
    s = sim.add_robot("r", 5.0, 10.0, 0.0, params=quiet_params())
    run(sim, "r", (1.0, 0.0, 0.0), 1.0)
    sim.command("r", 1.0, 0.0, 0.0)
    run(sim, "r", None, 0.25, hold=False)
    assert s.vel[0] == pytest.approx(1.0)  # still within the timeout
    run(sim, "r", None, 0.45, hold=False)  # timeout + 1.0 / 2.5 s of braking
    assert s.vel == (0.0, 0.0, 0.0)
    x = s.pose[0]
    run(sim, "r", None, 1.0, hold=False)
    assert s.pose[0] == x


def test_bad_commands_ignored_and_clamped():
    sim = Simulation(open_world())
    s = sim.add_robot("r", 10.0, 10.0, 0.0)
    assert "non-finite" in sim.command("r", float("nan"), 0.0, 0.0)
    assert "non-finite" in sim.command("r", 0.0, 0.0, float("inf"))
    assert s.cmd == (0.0, 0.0, 0.0)
    assert sim.command("r", 10.0, 0.0, -10.0) is None
    assert s.cmd == (s.params.max_vel_x, 0.0, -s.params.max_vel_theta)


def test_odometry_without_noise_equals_truth_and_drifts_with_noise():
    # odom_model ideal: only that model's odometry equals the truth when its noise is off
    # (skid adds its turn-dependent yaw scale); the skid model has test_odom_model.py.
    sim = Simulation(open_world(), seed=1)
    a = sim.add_robot("a", 5.0, 5.0, 0.3, params=quiet_params(), odom_model="ideal")
    b = sim.add_robot("b", 5.0, 12.0, 0.3, odom_model="ideal")
    for cmd in [(0.8, 0.0, 0.3)] * 1:
        run(sim, "a", cmd, 5.0)
    run(sim, "b", (0.8, 0.0, 0.3), 5.0)
    inc_true = geometry.relative((5.0, 5.0, 0.3), a.pose)
    np.testing.assert_allclose(a.odom_pose, inc_true, atol=1e-9)
    inc_b = geometry.relative((5.0, 12.0, 0.3), b.pose)
    err = math.hypot(b.odom_pose[0] - inc_b[0], b.odom_pose[1] - inc_b[1])
    assert 1e-4 < err < 0.5


def test_drift_variance_grows_with_distance_not_steps():
    p = rb.RobotParams(odom_trans_noise=0.05, odom_rot_noise=0.0, odom_rot_per_trans=0.0)
    rng = np.random.default_rng(0)

    def final_error(steps):
        x = 0.0
        for _ in range(steps):
            x += rb.noisy_increment(p, (1.0 / steps, 0.0, 0.0), rng)[0]
        return x - 1.0

    coarse = np.std([final_error(5) for _ in range(2000)])
    fine = np.std([final_error(50) for _ in range(300)])
    assert coarse == pytest.approx(0.05, rel=0.1)
    assert fine == pytest.approx(0.05, rel=0.2)
