"""The built-in world: generated files match the description, spots are free, the tour
driver gets round every room without touching anything; URDF geometry; world errors."""
import math
import os

import numpy as np
import pytest
import yaml

from summit_xl_sim.description import DescriptionError, fixed_joints, laser_mount
from summit_nav_common.map_io import GridMap, load_map
from summit_xl_sim.sim import Simulation
from summit_xl_sim.tour import TourParams, tour_command
from summit_xl_sim.world import World, WorldError
from summit_xl_sim.worldgen import WorldDescriptionError, build_world, load_description, world_spots

WORLDS = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "worlds")
DESC = os.path.join(WORLDS, "course_building.world.yaml")
URDF = os.path.join(WORLDS, "..", "urdf", "summit_xl.urdf")


def test_committed_map_is_the_drawn_description(tmp_path):
    _, yml = build_world(DESC, str(tmp_path / "w"))
    fresh, committed = load_map(yml), load_map(os.path.join(WORLDS, "course_building.yaml"))
    np.testing.assert_array_equal(fresh.data, committed.data)
    assert fresh.origin == committed.origin and fresh.resolution == committed.resolution


def test_spots_and_spawn_are_free():
    doc = load_description(DESC)
    sim = Simulation(World.from_yaml(os.path.join(WORLDS, "course_building.yaml")))
    for i, (label, (x, y, yaw_deg)) in enumerate(list(doc["spots"].items()) + [("spawn", doc["spawn"])]):
        if label == "spawn":
            yaw_deg = math.degrees(yaw_deg)
        sim.add_robot(f"r{i}", x, y, math.radians(yaw_deg))  # raises if blocked
        sim.robots.clear()
    assert set(doc["spots"]) == {"room", "turtle", "table"}


def test_world_spots_give_the_yaw_in_radians():
    doc = load_description(DESC)
    spots = world_spots(DESC)
    assert set(spots) == set(doc["spots"])
    for label, (x, y, yaw_deg) in doc["spots"].items():
        assert spots[label] == pytest.approx((x, y, math.radians(yaw_deg)))


def test_tour_visits_every_room_without_collision():
    world = World.from_yaml(os.path.join(WORLDS, "course_building.yaml"))
    with open(os.path.join(WORLDS, "course_building_tour.yaml")) as f:
        tour = yaml.safe_load(f)
    sim = Simulation(world, seed=0)
    s = sim.add_robot("r", *tour["start"])
    params, dt, control_every = TourParams(), 0.005, 10  # 20 Hz control
    rooms = {"hall": False, "room1": False, "room2": False, "fetch": False}
    i, n = 0, 0
    while i < len(tour["waypoints"]) and sim.time < 600.0:
        if n % control_every == 0:
            vx, wz, reached = tour_command(params, s.pose, tour["waypoints"][i])
            if reached:
                i += 1
                continue
            sim.command("r", vx, 0.0, wz)
        sim.step(dt)
        n += 1
        x, y = s.pose[0], s.pose[1]
        rooms["hall"] |= x < 12
        rooms["room1"] |= 12 < x < 16 and y > 7
        rooms["room2"] |= x > 16 and y > 7
        rooms["fetch"] |= x > 12 and y < 7
    assert i == len(tour["waypoints"]), f"stuck before waypoint {i} at {s.pose}"
    assert s.collisions == 0
    assert all(rooms.values()), rooms


def test_bad_world_files(tmp_path):
    with pytest.raises(WorldError, match="does not exist"):
        World.from_yaml(str(tmp_path / "none.yaml"))
    bad = tmp_path / "bad.world.yaml"
    bad.write_text("name: x\nresolution: 0.05\norigin: [0, 0]\nsize: [1, 1]\nbuilding: [0,0,1,1]\n"
                   "wall_thickness: 0.1\n")
    with pytest.raises(WorldDescriptionError, match="origin"):
        load_description(str(bad))


def test_urdf_laser_mount_and_level_check():
    joints = fixed_joints(open(URDF).read(), URDF)
    x, y, yaw = laser_mount(joints, source=URDF)
    assert (x, y, yaw) == pytest.approx((0.25, 0.0, 0.0))
    tilted = open(URDF).read().replace('xyz="0.25 0 0.32" rpy="0 0 0"', 'xyz="0.25 0 0.32" rpy="0 0.2 0"')
    with pytest.raises(DescriptionError, match="not mounted level"):
        laser_mount(fixed_joints(tilted), source="tilted")
    with pytest.raises(DescriptionError, match="malformed XML"):
        fixed_joints("<robot>", "broken")


def test_unknown_solid_beyond_field():
    """unknown_solid_beyond (the simulator's map field): unknown cells farther than it from
    every free cell are solid for the simulator's laser and collisions; nearer ones, and
    all of them without the field, are open space."""
    data = np.zeros((8, 40), np.int8)       # 20 m x 4 m at 0.5 m from (1, 2), free
    data[:, 20:26] = -1                     # an unknown band across the middle, x 11-14 m
    data[:, 36] = 100                       # a wall at x 19-19.5 m
    world = lambda beyond: World(GridMap(data=data.copy(), resolution=0.5, origin=(1.0, 2.0, 0.0),
                                         source={"unknown_solid_beyond": beyond}))
    open_world, closed, every = world(None), world(1.2), world(0.0)
    # The band's cell centres lie 0.5, 1.0, 1.5, 1.5, 1.0, 0.5 m from the free ones: with
    # 1.2 m its middle two columns (x 12-13 m) are solid, the outer two on each side open.
    ray = np.array([0.0])
    assert open_world.cast(3.0, 4.0, ray, 30.0)[0] == pytest.approx(16.0)
    assert closed.cast(3.0, 4.0, ray, 30.0)[0] == pytest.approx(9.0)
    assert every.cast(3.0, 4.0, ray, 30.0)[0] == pytest.approx(8.0)
    # Looking back along -x from x 3 m: the map's edge cell (x 1-1.5 m) is a wall.
    assert open_world.cast(3.0, 4.0, np.array([math.pi]), 30.0)[0] == pytest.approx(1.5)
    assert open_world.points_hit_walls(np.array([[1.2, 4.0]]))
    assert not open_world.points_hit_walls(np.array([[12.5, 4.0]]))
    assert closed.points_hit_walls(np.array([[12.5, 4.0]]))
    assert not closed.points_hit_walls(np.array([[11.7, 4.0]]))
    assert every.points_hit_walls(np.array([[11.7, 4.0]]))
