"""The odometry models (summit_xl_sim.robot, odom_model): ideal as it always was, skid's
turn-dependent yaw scale, its slowly varying part, its twist and its covariances."""
import math
import os

import numpy as np
import pytest

from summit_nav_common import geometry
from summit_nav_common.testing import scenes
from summit_xl_sim import robot as rb
from summit_xl_sim.sim import Simulation, default_odom_model
from summit_xl_sim.world import World, WorldError

BUILTIN = os.path.join(os.path.dirname(__file__), "..", "worlds", "course_building.yaml")


def open_world(size_m=40.0, res=0.05):
    """The simulator's world of scenes.square_room: walls on the border only."""
    return World(scenes.square_room(size_m, res))


def drive(sim, name, cmd, steps, dt=0.005):
    for _ in range(steps):
        sim.command(name, *cmd)
        sim.step(dt)


def test_ideal_unchanged_from_before_odom_model():
    """odom_model ideal gives the very odometry, truth and scans the simulator gave before
    odom_model existed (values recorded from that code, commit a67533b: built-in world,
    seed 11, robot at (2, 7, 0), three 2 s legs; every 200th beam of the scan after them).
    To 1e-12, not bit for bit: another machine's libm gave 1.3179394900904084 for the first
    x (one ulp off), which is no change of the model."""
    before = [((1.3179394900904087, 0.5886130585435703, 0.7967185584678216), (0.8, 0.0, 0.4),
               (3.3177529223645124, 7.581578101878069, 0.7849999999999158)),
              ((2.1059714996128833, 0.46381374448531987, -1.3675269433131378), (0.5, 0.0, -1.2),
               (4.106383683647579, 7.459221846567322, -1.3630000000001423)),
              ((2.2387839385695614, -1.4880291887082966, -1.5069928202524085), (1.0, 0.0, 0.0),
               (4.24388577805456, 5.513095220290167, -1.5040000000001421))]
    scan = [5.537729263305664, 3.610182285308838, 3.923449993133545, 5.464054107666016,
            3.804530382156372, 8.709942817687988]
    sim = Simulation(World.from_yaml(BUILTIN), seed=11)
    s = sim.add_robot("r", 2.0, 7.0, 0.0, odom_model="ideal")
    for cmd, (odom_pose, odom_vel, pose) in zip([(0.8, 0.0, 0.4), (0.5, 0.0, -1.2), (1.0, 0.0, 0.0)], before):
        drive(sim, "r", cmd, 400)
        assert s.odom_pose == pytest.approx(odom_pose, abs=1e-12) and s.odom_vel == odom_vel
        assert s.pose == pytest.approx(pose, abs=1e-12)
    np.testing.assert_array_equal(sim.scan("r")[::200], np.array(scan, np.float32))


def test_default_model_per_drive_and_bad_choices():
    assert default_odom_model("diff") == "skid" and default_odom_model("omni") == "ideal"
    sim = Simulation(open_world())
    assert sim.add_robot("d", 5.0, 5.0, 0.0).odom_model == "skid"
    assert sim.add_robot("o", 10.0, 5.0, 0.0, drive="omni").odom_model == "ideal"
    with pytest.raises(WorldError, match="robot 'x': odom_model must be one of"):
        sim.add_robot("x", 15.0, 5.0, 0.0, odom_model="slippy")
    with pytest.raises(WorldError, match="robot 'y': odom_model skid is the skid-steer base's"):
        sim.add_robot("y", 15.0, 5.0, 0.0, drive="omni", odom_model="skid")


def quiet_skid(**kw):
    """Skid odometry with its white noise and s(t) off: only a0 + a1 |wz| remains."""
    return rb.RobotParams(odom_trans_noise=0.0, odom_rot_noise=0.0, odom_rot_per_trans=0.0,
                          skid_yaw_scale_sd=0.0, **kw)


@pytest.mark.parametrize("wz", [0.3, 1.0, 2.5])
def test_skid_overestimates_rotation_more_on_a_fast_turn(wz):
    p = quiet_skid()
    sim = Simulation(open_world(), seed=2)
    s = sim.add_robot("r", 20.0, 20.0, 0.0, params=p)
    s.vel = (0.0, 0.0, wz)   # at speed already: the whole turn at wz
    turned_true = 0.0
    for _ in range(400):
        before = s.pose[2]
        drive(sim, "r", (0.0, 0.0, wz), 1)
        turned_true += geometry.wrap_angle(s.pose[2] - before)
    expected = 1.0 + p.skid_yaw_scale + p.skid_yaw_scale_per_radps * wz
    assert s.odom_pose[2] == pytest.approx(geometry.wrap_angle(turned_true * expected), abs=1e-9)
    assert s.odom_vel == pytest.approx((0.0, 0.0, wz * expected))   # the wheels' view
    assert s.vel == (0.0, 0.0, wz)


def test_skid_ratio_on_a_full_turn_with_all_noise_matches_the_constants():
    """A full turn on the spot at 1 rad/s, 200 seeds: the measured / true rotation's mean
    is 1 + a0 + a1 (4.5 %), its spread the white noise's and s(t)'s (about 1 %)."""
    p = rb.RobotParams()
    ratios = []
    for seed in range(200):
        rng, srng = np.random.default_rng([seed, 0]), np.random.default_rng([seed, 1])
        s, measured, dt, wz = 0.0, 0.0, 0.005, 1.0
        # s(t) starts at 0 in the simulation; here from its stationary law.
        s = srng.standard_normal() * p.skid_yaw_scale_sd
        for _ in range(int(round(2 * math.pi / (wz * dt)))):
            s = rb.skid_scale_step(p, s, dt, srng)
            measured += rb.skid_increment(p, (0.0, 0.0, wz * dt), wz, s, rng)[2]
        ratios.append(measured / (2 * math.pi))
    assert np.mean(ratios) == pytest.approx(1.0 + p.skid_yaw_scale + p.skid_yaw_scale_per_radps, abs=0.003)
    white = p.odom_rot_noise / math.sqrt(2 * math.pi)
    expected_sd = math.hypot(white, p.skid_yaw_scale_sd)   # s(t) barely changes in 6.3 s (tau 20 s)
    assert np.std(ratios) == pytest.approx(expected_sd, rel=0.2)


def test_gauss_markov_step_stationary_sd_and_correlation_time():
    sd, tau, dt = 0.01, 20.0, 0.5
    rng = np.random.default_rng(4)
    x = rng.standard_normal(20000) * sd
    x0 = x.copy()
    for _ in range(int(tau / dt)):
        x = rb.gauss_markov_step(x, dt, sd, tau, rng.standard_normal(x.shape))
    assert np.std(x) == pytest.approx(sd, rel=0.03)                        # stays stationary
    assert np.corrcoef(x0, x)[0, 1] == pytest.approx(math.exp(-1.0), abs=0.02)  # e^-1 after tau


def test_skid_straight_line_has_no_yaw_scale_effect():
    sim = Simulation(open_world(), seed=3)
    s = sim.add_robot("r", 5.0, 20.0, 0.0, params=quiet_skid())
    drive(sim, "r", (1.0, 0.0, 0.0), 1000)
    np.testing.assert_allclose(s.odom_pose, geometry.relative((5.0, 20.0, 0.0), s.pose), atol=1e-9)


def test_skid_draws_the_same_white_noise_and_laser_noise_as_ideal():
    """The skid model draws s(t) from its own generator and the same three normals as
    ideal per step from the robot's: on a straight drive (no rotation, so no yaw scale)
    both give the very same odometry and scans."""
    runs = []
    for model in ("ideal", "skid"):
        sim = Simulation(World.from_yaml(BUILTIN), seed=5)
        s = sim.add_robot("r", 2.0, 7.0, 0.0, odom_model=model)
        drive(sim, "r", (0.6, 0.0, 0.0), 400)
        runs.append((s.odom_pose, sim.scan("r")))
    assert runs[0][0] == runs[1][0]
    np.testing.assert_array_equal(runs[0][1], runs[1][1])


def test_skid_covariances_grow_with_the_turn_and_never_vanish():
    p = rb.RobotParams()
    rest = rb.skid_twist_covariance(p, (0.0, 0.0, 0.0))
    assert min(rest) == rb.MIN_ODOM_VARIANCE
    slow = rb.skid_twist_covariance(p, (0.5, 0.0, 0.3))
    fast = rb.skid_twist_covariance(p, (0.5, 0.0, 1.5))
    assert fast[2] > slow[2] > rest[2]
    excess = p.skid_yaw_scale + p.skid_yaw_scale_per_radps * 1.5
    assert fast[2] == pytest.approx((excess ** 2 + p.skid_yaw_scale_sd ** 2) * 1.5 ** 2)
    sim = Simulation(open_world(), seed=6)
    sim.add_robot("r", 20.0, 20.0, 0.0)
    pose_vars = []
    for _ in range(3):
        drive(sim, "r", (0.5, 0.0, 0.8), 200)
        pose_vars.append(sim.odom_covariance("r")[0])
    assert all(b[0] > a[0] and b[2] > a[2] for a, b in zip(pose_vars, pose_vars[1:]))
    sim.add_robot("i", 10.0, 10.0, 0.0, odom_model="ideal")
    assert sim.odom_covariance("i") is None
