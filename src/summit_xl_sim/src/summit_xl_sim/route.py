"""A lap route over a world: waypoints, the charging dock and the start pose.

The route file (summit_nav_common.route: ``waypoints``, ``dock``, ``start``) is the YAML
the cruise node reads (my_summit_navigation/config/race_track_waypoints.yaml) and the
simulator reads its ``dock`` from. This module reads it strictly (every entry usable,
every waypoint named), measures the lap (the closed polyline through the waypoints) and
draws it over the map for a picture. Pure: no rospy.
"""
import math

import cv2
import numpy as np

from summit_nav_common.map_io import FREE, OCCUPIED
from summit_nav_common.route import RouteError, read_route


def load_route(path):
    """Read a route file (summit_nav_common.route) for drawing and checking: returns
    {'waypoints': [(name, x, y, yaw_deg)], 'dock': (x, y, yaw_deg), 'start': (x, y,
    yaw_deg)} (dock and start None when absent). Every entry must be usable and every
    waypoint named: RouteError naming the file and the first bad entry otherwise."""
    route = read_route(path)
    waypoints = []
    for wp in route.waypoints:
        pose = wp.checked()
        if not isinstance(wp.name, str) or not wp.name:
            raise RouteError(f"{wp.where}: needs a non-empty 'name'")
        waypoints.append((wp.name,) + pose)
    return {"waypoints": waypoints,
            "dock": route.dock.checked() if route.dock is not None else None,
            "start": route.start.checked() if route.start is not None else None}


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
