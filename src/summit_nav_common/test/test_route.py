"""route: the race track's route file read into per-entry results; the file-level errors
name the file, a bad entry comes back with its reason; parse_pose's two forms and errors."""
import os

import pytest

from summit_nav_common.route import RouteError, parse_pose, read_route

TRACK = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "my_summit_navigation", "config",
                     "race_track_waypoints.yaml")


def test_the_race_track_route():
    route = read_route(TRACK)
    assert len(route.waypoints) >= 10 and all(w.error is None and isinstance(w.name, str) for w in route.waypoints)
    assert route.waypoints[0].name == "pit_exit" and route.waypoints[0].pose == (5.0, -6.5, 0.0)
    assert route.dock.pose is not None and route.start.pose is not None


def test_bad_entries_come_back_with_their_reasons(tmp_path):
    path = tmp_path / "r.yaml"
    path.write_text("waypoints:\n  - {name: a, x: 1, y: 2, yaw_deg: 90}\n  - [3, 4, 0]\n  - {name: b, x: 1}\n"
                    "  - 7\ndock: {x: .inf, y: 0, yaw_deg: 0}\n")
    route = read_route(str(path))
    a, unnamed, b, seven = route.waypoints
    assert (a.name, a.pose, a.error) == ("a", (1.0, 2.0, 90.0), None) and a.checked() == a.pose
    assert (unnamed.name, unnamed.pose) == (None, (3.0, 4.0, 0.0))
    assert b.name == "b" and b.pose is None and "missing field 'y'" in b.error
    assert seven.where == f"{path}: waypoints[3]" and "expected a mapping" in seven.error
    assert route.start is None and "finite" in route.dock.error
    with pytest.raises(RouteError, match=f"{path}: dock: x, y, yaw_deg must be finite"):
        route.dock.checked()


@pytest.mark.parametrize("text, message", [
    (None, "cannot read it"),
    ("waypoints: [", "malformed YAML"),
    ("- [1, 2, 3]\n", "expected a mapping with a non-empty list 'waypoints'"),
    ("dock: {x: 0, y: 0, yaw_deg: 0}\n", "non-empty list 'waypoints'.*got None"),
    ("waypoints: []\n", "non-empty list 'waypoints'"),
    ("waypoints: {a: 1}\n", "list 'waypoints'"),
])
def test_a_file_that_cannot_be_a_route_names_the_file(tmp_path, text, message):
    path = tmp_path / "r.yaml"
    if text is not None:
        path.write_text(text)
    with pytest.raises(RouteError, match=f"^{path}: .*{message}"):
        read_route(str(path))


def test_waypoints_may_be_optional(tmp_path):
    path = tmp_path / "r.yaml"
    path.write_text("dock: [1, 2, 180]\n")
    route = read_route(str(path), need_waypoints=False)
    assert route.waypoints == () and route.dock.pose == (1.0, 2.0, 180.0)
    path.write_text("waypoints: 3\n")
    with pytest.raises(RouteError, match="list 'waypoints'"):
        read_route(str(path), need_waypoints=False)


def test_parse_pose_forms_and_errors():
    assert parse_pose({"name": "a", "x": 1, "y": "2", "yaw_deg": -90}) == (1.0, 2.0, -90.0)
    assert parse_pose([1, 2, 3]) == parse_pose((1, 2, 3)) == (1.0, 2.0, 3.0)
    for bad, why in (({"x": 1, "y": 2}, "missing field 'yaw_deg'"), ([1, 2], "expected a mapping"),
                     ("1,2,3", "expected a mapping"), (None, "expected a mapping"),
                     ([1, "a", 0], "must be numbers"), ({"x": None, "y": 0, "yaw_deg": 0}, "must be numbers"),
                     ([float("nan"), 0, 0], "must be finite")):
        with pytest.raises(ValueError, match=why):
            parse_pose(bad)
