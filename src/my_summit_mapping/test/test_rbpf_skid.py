"""The RBPF core takes back a skid-steer base's rotation error at every filter update.

The story (issue 41): with the simulator's odometry default `skid` (every rotation read
2.5 % + 2 % per rad/s too large, plus a slow +-1 %), the rostest explore_two_rooms failed
three times in a row on a machine loaded 35-49, and slam_gmapping's handling of a 3-5 %
rotational odometry error was suspected. It is not the cause: here, on the same world,
turns on the spot at 1 rad/s (the odometry ends 16-21 deg off the truth) leave the best
particle within a degree of the true heading at every update, as the real gmapping's
scan matcher does on skid-steer bases; and one explore_two_rooms run on skid at load
10-25 passed (coverage 0.981, the robot's pose in the map within 6 mm and 0.5 deg of the
truth all along, the filter at most 4.5 s behind). At load 40-44 the same rostest failed
on skid and on ideal alike with the robot never moving: move_base published zero
velocities while its global plans came 10-16 s of simulated time (4x) after each goal,
and the oscillation watchdog (10 s) and explore's progress timeout (30 s), both in
simulated time, gave the goals up first.
"""
import math
import os

import numpy as np
import yaml

from my_summit_mapping.rbpf import RbpfSlam
from my_summit_mapping.slam_config import SlamConfig

from summit_xl_sim import sim as sim_mod
from summit_xl_sim.world import World

SRC = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
WORLD = os.path.join(SRC, "summit_xl_sim", "worlds", "two_rooms.yaml")
PARAMS = os.path.join(SRC, "my_summit_mapping", "config", "gmapping_params.yaml")
SIM_DT = 0.005        # [s]
COMMAND_EVERY = 10    # sim steps between commands (20 Hz, under the simulator's 0.25 s watchdog)
SCAN_EVERY = 5        # sim steps between scans (40 Hz)
TURN = 1.0            # [rad/s] on the spot, the fastest explore's DWA turns
TURN_TIME = 2 * math.pi   # [s]: one full turn each way and back


def wrap(a):
    return math.atan2(math.sin(a), math.cos(a))


def run(odom_model, seed=0):
    """Two full turns on the spot (left, then left again) in two_rooms' first room; returns
    (the worst |heading error| [rad] of the best particle at the filter updates, the
    odometry's |heading error| [rad] at the end, updates)."""
    sim = sim_mod.Simulation(World.from_yaml(WORLD), seed=seed)
    state = sim.add_robot("r", 1.5, 4.5, 0.0, odom_model=odom_model)
    with open(PARAMS) as f:
        params = yaml.safe_load(f)
    config = SlamConfig.from_dict({k: v for k, v in params.items() if k in SlamConfig.__dataclass_fields__})
    slam = RbpfSlam(config, np.random.default_rng(seed))
    mount = tuple(float(v) for v in state.laser.mount)
    angles = state.laser.angles() + mount[2]
    start = np.array(state.pose, float)   # the map frame is the odometry pose of the first scan
    worst = 0.0
    for n in range(int(2 * TURN_TIME / SIM_DT)):
        if n % COMMAND_EVERY == 0:
            sim.command("r", 0.0, 0.0, TURN)
        if n % SCAN_EVERY == 0:
            ranges = sim.scan("r").astype(float)
            ranges[ranges < state.laser.range_min] = np.inf
            if slam.process(state.odom_pose, ranges, angles, (mount[0], mount[1], 0.0), timestamp=sim.time,
                            range_max=state.laser.range_max):
                worst = max(worst, abs(wrap(slam.best_pose()[2] - (state.pose[2] - start[2]))))
        sim.step(SIM_DT)
    odom_error = abs(wrap(state.odom_pose[2] - (state.pose[2] - start[2])))
    return worst, odom_error, slam.update_count


def test_skid_rotation_error_is_matched_away_at_every_update():
    worst, odom_error, updates = run("skid")
    assert updates >= 20
    assert odom_error > math.radians(8.0), "the skid model no longer errs: this test would not see a failure"
    assert worst < math.radians(1.0), f"best particle {math.degrees(worst):.2f} deg off the true heading"
