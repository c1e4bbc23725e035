"""The race track world (issue 40): the committed map is its drawn description, with the
tutorial's map YAML; the lap's waypoints and the dock are in free space with room to
spare; the lap is 60-80 m; the robot spawns docked; worldgen's tracks (rounded centre
lines, width, walls) and the route file's errors."""
import math
import os

import numpy as np
import pytest
import yaml

from summit_nav_common.map_io import FREE, OCCUPIED, load_map
from summit_xl_sim.route import RouteError, lap_length, load_route
from summit_xl_sim.sim import Simulation
from summit_xl_sim.world import World
from summit_xl_sim.worldgen import (WorldDescriptionError, build_world, draw, load_description,
                                    polyline_length, round_corners)

HERE = os.path.dirname(os.path.abspath(__file__))
WORLDS = os.path.join(HERE, "..", "worlds")
DESC = os.path.join(WORLDS, "race_track.world.yaml")
MAP = os.path.join(WORLDS, "race_track.yaml")
ROUTE = os.path.join(HERE, "..", "..", "my_summit_navigation", "config", "race_track_waypoints.yaml")
WAYPOINT_CLEARANCE = 0.8  # [m] to every wall: room for the robot's 0.47 m circumradius and a margin
DOCK_CLEARANCE = 0.5      # [m] the dock sits beside the charger


@pytest.fixture(scope="module")
def world():
    return World.from_yaml(MAP)


@pytest.fixture(scope="module")
def route():
    return load_route(ROUTE)


def test_committed_map_is_the_drawn_description_with_the_tutorials_yaml(tmp_path):
    _, yml = build_world(DESC, str(tmp_path / "race_track"))
    fresh, committed = load_map(yml), load_map(MAP)
    np.testing.assert_array_equal(fresh.data, committed.data)
    with open(MAP) as f:
        meta = yaml.safe_load(f)
    assert meta == {"image": "race_track.pgm", "resolution": 0.05, "origin": [-10.0, -10.0, 0.0],
                    "occupied_thresh": 0.65, "free_thresh": 0.196, "negate": 0}


def test_circuit_centre_line_is_a_60_to_80_m_lap():
    doc = load_description(DESC)
    circuit = doc["tracks"]["circuit"]
    assert circuit["closed"] and 2.0 <= circuit["width"] <= 3.0
    assert 60.0 <= polyline_length(circuit["line"], True) <= 80.0


def test_waypoints_are_free_with_clearance_and_make_a_60_to_80_m_lap(world, route):
    for name, x, y, _ in route["waypoints"]:
        assert world.grid.data[world.grid.world_to_cell(x, y)[::-1]] == FREE, name
        assert world.clearance(x, y) >= WAYPOINT_CLEARANCE, (name, world.clearance(x, y))
    assert len(route["waypoints"]) >= 10
    assert 60.0 <= lap_length(route["waypoints"]) <= 80.0
    gaps = [math.hypot(b[1] - a[1], b[2] - a[2])
            for a, b in zip(route["waypoints"], route["waypoints"][1:] + route["waypoints"][:1])]
    assert 3.0 <= min(gaps) and max(gaps) <= 10.0, gaps


def test_dock_is_free_start_is_the_dock_and_the_robot_spawns_there(world, route):
    x, y, yaw_deg = route["dock"]
    assert world.grid.data[world.grid.world_to_cell(x, y)[::-1]] == FREE
    assert world.clearance(x, y) >= DOCK_CLEARANCE
    assert route["start"] == route["dock"]
    doc = load_description(DESC)
    np.testing.assert_allclose(doc["spawn"], [x, y, math.radians(yaw_deg)])
    np.testing.assert_allclose(doc["spots"]["dock"], [x, y, yaw_deg])
    Simulation(world).add_robot("r", x, y, math.radians(yaw_deg))  # raises if blocked


def test_narrow_section_is_about_twice_the_robots_width(world):
    grid = world.grid
    col = grid.world_to_cell(-1.5, 1.5)[0]
    column = grid.data[:, col]
    row0 = grid.world_to_cell(-1.5, 1.5)[1]
    up = next(r for r in range(row0, grid.height) if column[r] == OCCUPIED)
    down = next(r for r in range(row0, -1, -1) if column[r] == OCCUPIED)
    width = (up - down - 1) * grid.resolution
    assert 1.3 - 1e-9 <= width <= 1.4 + 1e-9, width


def test_round_corners_square_has_the_arcs_length():
    side, r = 4.0, 1.0
    line = round_corners([(0, 0, r), (side, 0, r), (side, side, r), (0, side, r)], closed=True, step=0.01)
    expected = 4 * side - 8 * r + 2 * math.pi * r  # straight parts + four quarter circles
    assert polyline_length(line, True) == pytest.approx(expected, abs=1e-3)
    # Every point of a rounded corner is r from its arc centre (here (3, 3) for the NE one).
    ne = np.array([p for p in line if p[0] > 3.0 + 1e-9 and p[1] > 3.0 + 1e-9])
    np.testing.assert_allclose(np.hypot(ne[:, 0] - 3.0, ne[:, 1] - 3.0), r, atol=1e-9)


def test_round_corners_refuses_overlapping_arcs_and_turning_back():
    with pytest.raises(ValueError, match=r"centre\[1\] and centre\[2\]"):
        round_corners([(0, 0, 0), (2, 0, 1.5), (2, 2, 1.5), (0, 2, 0)], closed=False)
    with pytest.raises(ValueError, match="180 deg"):
        round_corners([(0, 0, 0), (2, 0, 0.5), (0, 0, 0)], closed=False)
    with pytest.raises(ValueError, match="coincide"):
        round_corners([(0, 0, 0), (0, 0, 0), (1, 0, 0)], closed=False)


def _track_doc(**track):
    return {"name": "t", "resolution": 0.05, "origin": [-1.0, -2.0, 0.0], "size": [6.0, 4.0],
            "wall_thickness": 0.15, "tracks": {"road": track}}


def test_straight_track_has_its_width_and_walls(tmp_path):
    path = tmp_path / "t.world.yaml"
    path.write_text(yaml.safe_dump(_track_doc(width=1.0, closed=False, centre=[[0, 0], [4, 0]])))
    img = draw(load_description(str(path)))
    column = img[:, int(2.0 / 0.05)][::-1]  # x = 1 m, bottom-up: y = -2 .. 2
    free = np.flatnonzero(column == 254)
    walls = np.flatnonzero(column == 0)
    assert len(free) * 0.05 == pytest.approx(1.0, abs=0.051)  # within a cell
    assert len(walls) * 0.05 == pytest.approx(2 * 0.15, abs=0.1)
    assert set(np.unique(column)) == {0, 205, 254}  # unknown outside the walls


@pytest.mark.parametrize("track, message", [
    ({"width": 0.0, "closed": False, "centre": [[0, 0], [1, 0]]}, "width: must be > 0"),
    ({"width": 1.0, "closed": "yes", "centre": [[0, 0], [1, 0]]}, "closed: expected true or false"),
    ({"width": 1.0, "closed": True, "centre": [[0, 0], [1, 0]]}, "at least 3 points"),
    ({"width": 1.0, "closed": False, "centre": [[0, 0], [1, "a"]]}, r"centre\[1\]"),
    ({"width": 1.0, "closed": False, "centre": [[0, 0], [1, 0, -1], [2, 1]]}, "radius must be >= 0"),
])
def test_bad_tracks_are_named(tmp_path, track, message):
    path = tmp_path / "t.world.yaml"
    path.write_text(yaml.safe_dump(_track_doc(**track)))
    with pytest.raises(WorldDescriptionError, match=r"tracks\.road.*" + message):
        load_description(str(path))


def test_description_without_free_space_is_refused(tmp_path):
    doc = _track_doc(width=1.0, closed=False, centre=[[0, 0], [1, 0]])
    del doc["tracks"]
    path = tmp_path / "t.world.yaml"
    path.write_text(yaml.safe_dump(doc))
    with pytest.raises(WorldDescriptionError, match="missing field 'building'"):
        load_description(str(path))


@pytest.mark.parametrize("text, message", [
    ("waypoints: []", "non-empty list 'waypoints'"),
    ("waypoints: [{name: a, x: 1, y: 2}]", r"waypoints\[0\]: missing field 'yaw_deg'"),
    ("waypoints: [{x: 1, y: 2, yaw_deg: 0}]", r"waypoints\[0\]: needs a non-empty 'name'"),
    ("waypoints: [{name: a, x: 1, y: 2, yaw_deg: 0}]\ndock: [1, 2]", "dock: expected a mapping"),
    ("waypoints: [{name: a, x: .nan, y: 2, yaw_deg: 0}]", "finite"),
    ("waypoints: [", "malformed YAML"),
])
def test_bad_route_files_are_named(tmp_path, text, message):
    path = tmp_path / "route.yaml"
    path.write_text(text)
    with pytest.raises(RouteError, match=str(path) + ".*" + message):
        load_route(str(path))
