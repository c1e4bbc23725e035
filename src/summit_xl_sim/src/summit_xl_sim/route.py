"""A lap route over a world: waypoints, the charging dock and the start pose.

The route file is the YAML the cruise node reads (my_summit_navigation/config/
race_track_waypoints.yaml) and the simulator reads its ``dock`` from::

    waypoints: [{name: str, x: m, y: m, yaw_deg: deg}, ...]   # one lap, in driving order
    dock: {x: m, y: m, yaw_deg: deg}    # base_footprint's pose when docked
    start: {x: m, y: m, yaw_deg: deg}   # spawn pose

This module reads and checks it (clearance of each pose in a World, lap length: the
closed polyline through the waypoints) and draws it over the map for a picture. Pure:
no rospy.
"""
import math

import cv2
import numpy as np
from summit_nav_common.files import load_yaml
from summit_nav_common.map_io import FREE, OCCUPIED


class RouteError(ValueError):
    """A route file that cannot be used; the message names the file and the entry."""


def _pose(entry, where, named=False):
    if not isinstance(entry, dict):
        raise RouteError(f"{where}: expected a mapping {{{'name, ' if named else ''}x, y, yaw_deg}}, got {entry!r}")
    try:
        pose = tuple(float(entry[k]) for k in ("x", "y", "yaw_deg"))
    except KeyError as e:
        raise RouteError(f"{where}: missing field {e}") from None
    except (TypeError, ValueError):
        raise RouteError(f"{where}: x, y, yaw_deg must be numbers, got {entry!r}") from None
    if not all(math.isfinite(v) for v in pose):
        raise RouteError(f"{where}: x, y, yaw_deg must be finite, got {entry!r}")
    if named:
        name = entry.get("name")
        if not isinstance(name, str) or not name:
            raise RouteError(f"{where}: needs a non-empty 'name'")
        return (name,) + pose
    return pose


def load_route(path):
    """Read a route YAML; returns {'waypoints': [(name, x, y, yaw_deg)], 'dock': (x, y,
    yaw_deg), 'start': (x, y, yaw_deg)} (dock and start None when absent)."""
    doc = load_yaml(path, RouteError)
    if not isinstance(doc, dict) or not isinstance(doc.get("waypoints"), list) or not doc["waypoints"]:
        raise RouteError(f"{path}: expected a mapping with a non-empty list 'waypoints'")
    route = {"waypoints": [_pose(w, f"{path}: waypoints[{i}]", named=True)
                           for i, w in enumerate(doc["waypoints"])]}
    for key in ("dock", "start"):
        route[key] = _pose(doc[key], f"{path}: {key}") if doc.get(key) is not None else None
    return route


def lap_length(waypoints):
    """Length [m] of the closed polyline through the waypoints [(name, x, y, yaw_deg)]."""
    pts = [(w[1], w[2]) for w in waypoints]
    return sum(math.hypot(b[0] - a[0], b[1] - a[1]) for a, b in zip(pts, pts[1:] + pts[:1]))


def draw_route(grid, route, scale=4):
    """A BGR picture (rows top-down) of the map with the lap, waypoints and dock.

    grid: map_io.GridMap (origin yaw 0); scale: pixels per cell. Free cells white,
    unknown grey, occupied black; the lap in blue with numbered waypoints (arrows show
    their yaw), the dock in green, the start in red.
    """
    h, w = grid.data.shape
    img = np.full((h, w, 3), 160, np.uint8)
    img[grid.data == FREE] = 255
    img[grid.data == OCCUPIED] = 0
    img = cv2.resize(img[::-1], (w * scale, h * scale), interpolation=cv2.INTER_NEAREST)
    ox, oy = grid.origin[0], grid.origin[1]

    def px(x, y):
        return (int(round((x - ox) / grid.resolution * scale)),
                int(round(h * scale - (y - oy) / grid.resolution * scale)))

    def arrow(x, y, yaw_deg, colour, length=0.6):
        yaw = math.radians(yaw_deg)
        cv2.arrowedLine(img, px(x, y), px(x + length * math.cos(yaw), y + length * math.sin(yaw)),
                        colour, 2, cv2.LINE_AA, tipLength=0.35)

    wps = route["waypoints"]
    pts = np.array([px(wp[1], wp[2]) for wp in wps], np.int32)
    cv2.polylines(img, [pts], True, (230, 140, 40), 2, cv2.LINE_AA)
    for i, (name, x, y, yaw_deg) in enumerate(wps):
        cv2.circle(img, px(x, y), 7, (200, 90, 0), -1, cv2.LINE_AA)
        arrow(x, y, yaw_deg, (200, 90, 0))
        cx, cy = px(x, y)
        cv2.putText(img, f"{i + 1} {name}", (cx + 9, cy - 9), cv2.FONT_HERSHEY_SIMPLEX, 0.45,
                    (120, 40, 0), 1, cv2.LINE_AA)
    for key, colour in (("dock", (0, 160, 0)), ("start", (0, 0, 220))):
        if route.get(key) is not None:
            x, y, yaw_deg = route[key]
            cv2.circle(img, px(x, y), 9 if key == "dock" else 5, colour, 2, cv2.LINE_AA)
            arrow(x, y, yaw_deg, colour)
            cx, cy = px(x, y)
            cv2.putText(img, key, (cx - 12, cy + (24 if key == "dock" else 38)), cv2.FONT_HERSHEY_SIMPLEX,
                        0.5, colour, 1, cv2.LINE_AA)
    return img
