"""Simulation: collisions with walls, boxes and robots; spawning errors; scans."""
import math
import os

import numpy as np
import pytest

from summit_xl_sim import robot as rb
from summit_xl_sim.sim import LaserParams, Simulation
from summit_xl_sim.world import World, WorldError

HERE = os.path.dirname(os.path.abspath(__file__))
BUILTIN = os.path.join(HERE, "..", "worlds", "course_building.yaml")


@pytest.fixture(scope="module")
def world():
    return World.from_yaml(BUILTIN)


def fresh(world):
    world.boxes.clear()
    return Simulation(world, seed=3)


def drive(sim, name, cmd, seconds, dt=0.005):
    for _ in range(int(round(seconds / dt))):
        sim.command(name, *cmd)
        sim.step(dt)


def test_driving_into_a_wall_stops_and_counts_once(world):
    sim = fresh(world)
    s = sim.add_robot("r", 2.0, 9.0, math.pi)  # facing the west wall, 2 m away
    drive(sim, "r", (1.0, 0.0, 0.0), 5.0)
    # The wall's inner face: the right edge of the last wall cell on this row.
    row = int((9.0 - world.origin[1]) / world.resolution)
    last_wall = np.nonzero(world.walls[row, :60])[0].max()
    face = world.origin[0] + (last_wall + 1) * world.resolution
    front = s.pose[0] - 0.36
    assert face - 1e-9 <= front < face + 0.006  # stopped within one 5 mm step of the wall
    assert s.collisions == 1 and s.last_hit == "wall"
    drive(sim, "r", (-0.5, 0.0, 0.0), 1.0)  # backing off works
    assert s.pose[0] > 0.9
    assert s.collisions == 1


def test_box_blocks_and_is_seen(world):
    sim = fresh(world)
    s = sim.add_robot("r", 6.0, 7.0, 0.0)
    before = sim.scan("r", noise=False)[540]
    sim.add_box("b", 8.0, 7.0, 0.0, 0.5, 0.5)
    r = sim.scan("r", noise=False)
    # laser at x = 6.25; box face at 7.75
    assert r[540] == pytest.approx(1.5, abs=1e-6)
    assert before > 3.0
    drive(sim, "r", (1.0, 0.0, 0.0), 3.0)
    assert s.collisions == 1 and s.pose[0] + 0.36 <= 7.75 + 1e-9 and s.last_hit == "box b"
    sim.world.remove_box("b")
    with pytest.raises(WorldError, match="no box named 'b'"):
        sim.world.remove_box("b")


def test_robots_see_and_block_each_other(world):
    sim = fresh(world)
    a = sim.add_robot("robot_0", 5.0, 7.0, 0.0)
    sim.add_robot("robot_1", 8.0, 7.0, math.pi)
    ra, rb_ = sim.scan("robot_0", noise=False), sim.scan("robot_1", noise=False)
    # a's laser at 5.25, b's rear face at 8.36 -> 3.11; b's laser at 7.75, a's front at 5.36
    assert ra[540] == pytest.approx(8.0 - 0.36 - 5.25, abs=1e-6)
    assert rb_[540] == pytest.approx(7.75 - 5.36, abs=1e-6)
    drive(sim, "robot_0", (1.0, 0.0, 0.0), 4.0)
    assert a.collisions == 1 and a.last_hit == "robot robot_1"
    assert a.pose[0] + 0.36 <= 8.0 - 0.36 + 1e-9


def test_spawn_errors_name_robot_and_reason(world):
    sim = fresh(world)
    with pytest.raises(WorldError, match="'r'.*overlaps a wall"):
        sim.add_robot("r", 12.0, 6.0, 0.0)
    with pytest.raises(WorldError, match="off the map"):
        sim.add_robot("r", 50.0, 6.0, 0.0)
    with pytest.raises(WorldError, match="not finite"):
        sim.add_robot("r", float("nan"), 6.0, 0.0)
    sim.add_robot("r", 2.0, 7.0, 0.0)
    with pytest.raises(WorldError, match="overlaps a robot r"):
        sim.add_robot("q", 2.3, 7.0, 0.0)
    with pytest.raises(WorldError, match="overlap robot 'r'"):
        sim.add_box("b", 2.0, 7.0, 0.0, 0.3, 0.3)


def test_set_pose_teleports_truth_not_odometry(world):
    sim = fresh(world)
    s = sim.add_robot("r", 2.0, 7.0, 0.0)
    sim.set_pose("r", 16.0, 3.5, 1.0)
    assert s.pose == (16.0, 3.5, 1.0) and s.odom_pose == (0.0, 0.0, 0.0)
    with pytest.raises(WorldError, match="cannot place"):
        sim.set_pose("r", 12.0, 6.0, 0.0)


@pytest.mark.parametrize("model", ["utm30lx", "ideal"])
def test_scan_conventions(world, model):
    sim = fresh(world)
    sim.add_robot("r", 6.0, 7.0, 0.0, laser=LaserParams(model=model))
    r = sim.scan("r")
    assert r.dtype == np.float32 and r.shape == (1081,)
    finite = r[np.isfinite(r)]
    assert finite.min() >= 0.10 and finite.max() <= 30.0
    exact = sim.scan("r", noise=False)
    assert np.isfinite(r).sum() <= np.isfinite(exact).sum()  # noise never invents a return
    if model == "ideal":
        # Noise: sigma 0.01 m around the exact range (utm30lx: test_laser_model.py)
        d = (r - exact)[np.isfinite(r)]
        assert 0.007 < d.std() < 0.013
