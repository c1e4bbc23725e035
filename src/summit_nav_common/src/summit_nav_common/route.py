"""The lap route file: waypoints in driving order, the charging dock and the start pose.

The race track's route (my_summit_navigation/config/race_track_waypoints.yaml) is read
by the cruise node (auto_navigator), the health report (nav_health) and the simulator's
route drawing (draw_route)::

    waypoints: [{name: str, x: m, y: m, yaw_deg: deg}, ...]   # one lap, in driving order
    dock: {x: m, y: m, yaw_deg: deg}    # optional: base_footprint's pose when docked
    start: {x: m, y: m, yaw_deg: deg}   # optional: the spawn pose

A pose may also be written as a list [x, y, yaw_deg]; other keys are ignored.

``read_route`` checks the file as a whole and each pose entry on its own. A file that
cannot be read, is not a mapping, or has no (non-empty) list ``waypoints`` raises
RouteError naming the file. A bad entry (waypoint, dock or start) does not raise: it
comes back as a RouteEntry with its reason, and each reader decides what a bad entry
means (the drawing refuses the file, the cruise skips that waypoint every lap).
``parse_pose`` is the one parser of a pose entry, also for poses that come from ROS
parameters. Pure: no rospy.
"""
import math
from dataclasses import dataclass

from summit_nav_common.files import load_yaml

POSE_KEYS = ("x", "y", "yaw_deg")   # [m], [m], [deg]


class RouteError(ValueError):
    """A route file that cannot be used; the message names the file and the entry."""


def parse_pose(entry):
    """(x [m], y [m], yaw_deg [deg]) of {x, y, yaw_deg} (other keys ignored) or
    [x, y, yaw_deg], all finite numbers. ValueError saying why otherwise (the caller
    names where the entry comes from)."""
    if isinstance(entry, dict):
        missing = [k for k in POSE_KEYS if k not in entry]
        if missing:
            raise ValueError(f"missing field '{missing[0]}' in {entry!r}")
        values = [entry[k] for k in POSE_KEYS]
    elif isinstance(entry, (list, tuple)) and len(entry) == len(POSE_KEYS):
        values = list(entry)
    else:
        raise ValueError(f"expected a mapping {{x, y, yaw_deg}} or a list [x, y, yaw_deg], got {entry!r}")
    try:
        pose = tuple(float(v) for v in values)
    except (TypeError, ValueError):
        raise ValueError(f"x, y, yaw_deg must be numbers, got {entry!r}") from None
    if not all(math.isfinite(v) for v in pose):
        raise ValueError(f"x, y, yaw_deg must be finite, got {entry!r}")
    return pose


@dataclass(frozen=True)
class RouteEntry:
    """One pose entry of a route file: where it is ("<file>: waypoints[3]", "<file>:
    dock"), its ``name`` as written (None when it has none), and either its pose
    (x [m], y [m], yaw_deg [deg]) or the reason it has none (``error``)."""

    where: str
    name: object = None
    pose: tuple = None
    error: str = None

    def checked(self):
        """The pose; RouteError "<where>: <error>" when the entry has none."""
        if self.error is not None:
            raise RouteError(f"{self.where}: {self.error}")
        return self.pose


@dataclass(frozen=True)
class Route:
    """A route file's entries: waypoints (RouteEntry, in driving order), and dock and
    start (RouteEntry, or None when the file has none)."""

    path: str
    waypoints: tuple
    dock: RouteEntry = None
    start: RouteEntry = None


def _entry(value, where):
    name = value.get("name") if isinstance(value, dict) else None
    try:
        return RouteEntry(where, name, pose=parse_pose(value))
    except ValueError as e:
        return RouteEntry(where, name, error=str(e))


def read_route(path, need_waypoints=True):
    """The Route in the YAML file at path. RouteError naming the file when it cannot be
    read, is not a mapping, or its ``waypoints`` is not a list (or, with need_waypoints,
    is missing or empty); bad entries come back with their reasons."""
    doc = load_yaml(path, RouteError)
    found = doc.get("waypoints") if isinstance(doc, dict) else doc
    waypoints = [] if found is None and not need_waypoints else found
    if not isinstance(doc, dict) or not isinstance(waypoints, list) or (need_waypoints and not waypoints):
        raise RouteError(f"{path}: expected a mapping with a {'non-empty ' if need_waypoints else ''}list "
                         f"'waypoints' ([{{name, x, y, yaw_deg}}, ...]), got {found!r}")
    ends = {key: _entry(doc[key], f"{path}: {key}") if doc.get(key) is not None else None
            for key in ("dock", "start")}
    return Route(str(path), tuple(_entry(w, f"{path}: waypoints[{i}]") for i, w in enumerate(waypoints)), **ends)
