"""Draw a world description (walls with doors, tracks, rectangles, circles) into a map_server map.

The built-in world is kept as a readable YAML description (worlds/*.world.yaml); this
module rasterizes it with OpenCV polygons (sub-pixel precision) at the description's
resolution: unknown (205) outside the building, free (254) inside, walls and furniture
occupied (0), exactly the trinary image map_saver would write.

Tracks (roads with a wall on each side, as on a race circuit) are given by their centre
line, a polyline whose corners may be rounded with a radius (a fillet: the arc tangent to
both legs, as in CAD). A track of width w is the set of points within w/2 of its centre
line (a Minkowski sum with a disc), so every point of the centre line has exactly w/2 of
clearance; its walls are the band from w/2 to w/2 + wall_thickness. All tracks' walls are
drawn before any track's road, so where two tracks meet (a pit lane joining the main
straight) the road cuts through the wall and they connect.
"""
import math

import cv2
import numpy as np

from summit_nav_common.files import load_yaml
from summit_nav_common.map_io import PGM_FREE, PGM_OCCUPIED, PGM_UNKNOWN, GridMap, MapError, save_map, image_to_grid

SHIFT = 4                 # OpenCV fixed-point bits for sub-pixel drawing
SCALE = 1 << SHIFT


class WorldDescriptionError(ValueError):
    """A world description that cannot be drawn; the message names the file and entry."""


def _num_list(value, n, where):
    try:
        vals = [float(v) for v in value]
    except (TypeError, ValueError):
        raise WorldDescriptionError(f"{where}: expected {n} numbers, got {value!r}") from None
    if len(vals) != n or not all(math.isfinite(v) for v in vals):
        raise WorldDescriptionError(f"{where}: expected {n} finite numbers, got {value!r}")
    return vals


def load_description(path):
    """Read and validate a world description YAML; returns a dict."""
    doc = load_yaml(path, WorldDescriptionError)
    if not isinstance(doc, dict):
        raise WorldDescriptionError(f"{path}: expected a mapping")
    for key in ("name", "resolution", "origin", "size", "wall_thickness"):
        if key not in doc:
            raise WorldDescriptionError(f"{path}: missing field '{key}'")
    if "building" not in doc and not doc.get("tracks"):
        raise WorldDescriptionError(f"{path}: missing field 'building' (or 'tracks'): no free space to draw")
    doc["origin"] = _num_list(doc["origin"], 3, f"{path}: origin")
    doc["size"] = _num_list(doc["size"], 2, f"{path}: size")
    if "building" in doc:
        doc["building"] = _num_list(doc["building"], 4, f"{path}: building")
    doc["tracks"] = {k: _load_track(v, f"{path}: tracks.{k}") for k, v in (doc.get("tracks") or {}).items()}
    for i, wall in enumerate(doc.get("walls", [])):
        where = f"{path}: walls[{i}]"
        wall["from"] = _num_list(wall.get("from"), 2, where + ".from")
        wall["to"] = _num_list(wall.get("to"), 2, where + ".to")
        wall["doors"] = [_num_list(d, 2, where + ".doors") for d in wall.get("doors", [])]
    doc["rects"] = {k: _num_list(v, 5, f"{path}: rects.{k}") for k, v in (doc.get("rects") or {}).items()}
    doc["circles"] = {k: _num_list(v, 3, f"{path}: circles.{k}") for k, v in (doc.get("circles") or {}).items()}
    doc["spots"] = {k: _num_list(v, 3, f"{path}: spots.{k}") for k, v in (doc.get("spots") or {}).items()}
    if "spawn" in doc:
        doc["spawn"] = _num_list(doc["spawn"], 3, f"{path}: spawn")
    return doc


def world_spots(path):
    """{label: (x [m], y [m], yaw [rad])} of a world description's spots (world frame;
    the YAML gives yaw in degrees)."""
    return {k: (v[0], v[1], math.radians(v[2])) for k, v in load_description(path)["spots"].items()}


def _load_track(track, where):
    """Validate one track entry {width, closed, centre: [[x, y] or [x, y, radius], ...]}."""
    if not isinstance(track, dict):
        raise WorldDescriptionError(f"{where}: expected a mapping with width, closed, centre")
    width = _num_list([track.get("width")], 1, where + ".width")[0]
    if width <= 0.0:
        raise WorldDescriptionError(f"{where}.width: must be > 0 [m], got {width}")
    closed = track.get("closed", False)
    if not isinstance(closed, bool):
        raise WorldDescriptionError(f"{where}.closed: expected true or false, got {closed!r}")
    centre = track.get("centre")
    if not isinstance(centre, list) or len(centre) < (3 if closed else 2):
        raise WorldDescriptionError(f"{where}.centre: expected a list of at least "
                                    f"{3 if closed else 2} points, got {centre!r}")
    points = []
    for i, pt in enumerate(centre):
        n = len(pt) if isinstance(pt, (list, tuple)) and len(pt) in (2, 3) else 2
        vals = _num_list(pt, n, f"{where}.centre[{i}]")
        points.append((vals[0], vals[1], vals[2] if n == 3 else 0.0))
    try:
        line = round_corners(points, closed)
    except ValueError as e:
        raise WorldDescriptionError(f"{where}: {e}") from None
    return {"width": width, "closed": closed, "centre": points, "line": line}


def round_corners(points, closed, step=0.05):
    """The centre line of a track: polyline vertices with rounded corners.

    points: [(x, y, radius)] [m]; a corner with radius > 0 is replaced by the arc of that
    radius tangent to both legs (sampled every ``step`` [m] at most); radius 0 keeps the
    sharp corner (the ends of an open line are never rounded). Returns [(x, y)] [m]; for
    a closed line the last point does not repeat the first. ValueError naming the vertex
    when a radius is negative, two vertices coincide or the arcs of a leg overlap.
    """
    n = len(points)
    legs = n if closed else n - 1

    def unit(i):  # direction and length of leg i (from vertex i to vertex i + 1)
        (x0, y0, _), (x1, y1, _) = points[i % n], points[(i + 1) % n]
        length = math.hypot(x1 - x0, y1 - y0)
        if length == 0.0:
            raise ValueError(f"centre[{i % n}] and centre[{(i + 1) % n}] coincide")
        return (x1 - x0) / length, (y1 - y0) / length, length

    cut = [0.0] * n          # leg length [m] each corner's arc takes from each of its legs
    arcs = [None] * n
    for i in range(n):
        x, y, r = points[i]
        if r < 0.0:
            raise ValueError(f"centre[{i}]: corner radius must be >= 0 [m], got {r}")
        if r == 0.0 or (not closed and i in (0, n - 1)):
            continue
        ax, ay, _ = unit(i - 1)
        bx, by, _ = unit(i)
        turn = math.atan2(ax * by - ay * bx, ax * bx + ay * by)  # signed heading change [rad]
        if abs(turn) < 1e-9:
            continue
        if abs(turn) > math.pi - 1e-6:
            raise ValueError(f"centre[{i}]: the line turns back on itself (180 deg); "
                             f"make a hairpin of two 90 deg corners")
        cut[i] = r * math.tan(abs(turn) / 2.0)
        # Arc centre: from the tangent point on the incoming leg, r to the inside of the turn.
        tx, ty = x - ax * cut[i], y - ay * cut[i]
        side = 1.0 if turn > 0 else -1.0
        cx, cy = tx - side * ay * r, ty + side * ax * r
        start = math.atan2(ty - cy, tx - cx)
        arcs[i] = (cx, cy, r, start, turn)
    for i in range(legs):
        length = unit(i)[2]
        if cut[i] + cut[(i + 1) % n] > length + 1e-9:
            raise ValueError(f"the corners at centre[{i}] and centre[{(i + 1) % n}] need "
                             f"{cut[i] + cut[(i + 1) % n]:.2f} m of their {length:.2f} m leg: "
                             f"make their radii smaller")
    line = []
    for i in range(n):
        x, y, _ = points[i]
        if arcs[i] is None:
            line.append((x, y))
            continue
        cx, cy, r, start, turn = arcs[i]
        k = max(1, int(math.ceil(abs(turn) * r / step)))
        line.extend((cx + r * math.cos(start + turn * j / k), cy + r * math.sin(start + turn * j / k))
                    for j in range(k + 1))
    return line


def polyline_length(line, closed):
    """Length [m] of a polyline [(x, y)], including the closing leg when ``closed``."""
    pts = list(line) + ([line[0]] if closed else [])
    return sum(math.hypot(b[0] - a[0], b[1] - a[1]) for a, b in zip(pts, pts[1:]))


def wall_pieces(wall):
    """The solid pieces [(x1, y1, x2, y2)] of a wall once its doors are cut out."""
    (x1, y1), (x2, y2) = wall["from"], wall["to"]
    length = math.hypot(x2 - x1, y2 - y1)
    ux, uy = (x2 - x1) / length, (y2 - y1) / length
    cuts = sorted(wall.get("doors", []))
    pieces, start = [], 0.0
    for a, b in cuts + [[length, length]]:
        if a > start:
            pieces.append((x1 + ux * start, y1 + uy * start, x1 + ux * a, y1 + uy * a))
        start = max(start, b)
    return pieces


def draw(doc):
    """Rasterize a description into trinary pixels (rows top-down, uint8)."""
    res = float(doc["resolution"])
    ox, oy, _ = doc["origin"]
    width, height = int(round(doc["size"][0] / res)), int(round(doc["size"][1] / res))
    img = np.full((height, width), PGM_UNKNOWN, np.uint8)

    def px(x, y):  # world [m] -> fixed-point pixel coordinates (x right, y down)
        # OpenCV puts pixel centres on integer coordinates, hence the half-pixel shift.
        return (int(round(((x - ox) / res - 0.5) * SCALE)),
                int(round((height - (y - oy) / res - 0.5) * SCALE)))

    def poly(corners, value):
        pts = np.array([px(x, y) for x, y in corners], np.int32)
        cv2.fillPoly(img, [pts], int(value), lineType=cv2.LINE_8, shift=SHIFT)

    def band(line, closed, half_width, value):
        # Minkowski sum of the polyline and a disc: a quad per leg, a disc per vertex.
        pts = list(line) + ([line[0]] if closed else [])
        for (x1, y1), (x2, y2) in zip(pts, pts[1:]):
            length = math.hypot(x2 - x1, y2 - y1)
            if length == 0.0:
                continue
            nx, ny = -(y2 - y1) / length * half_width, (x2 - x1) / length * half_width
            poly([(x1 + nx, y1 + ny), (x2 + nx, y2 + ny), (x2 - nx, y2 - ny), (x1 - nx, y1 - ny)], value)
        for x, y in pts:
            cv2.circle(img, px(x, y), int(round(half_width / res * SCALE)), int(value),
                       thickness=-1, lineType=cv2.LINE_8, shift=SHIFT)

    if "building" in doc:
        bx0, by0, bx1, by1 = doc["building"]
        poly([(bx0, by0), (bx1, by0), (bx1, by1), (bx0, by1)], PGM_FREE)
    half_t = float(doc["wall_thickness"]) / 2.0
    for track in doc["tracks"].values():
        band(track["line"], track["closed"], track["width"] / 2.0 + 2.0 * half_t, PGM_OCCUPIED)
    for track in doc["tracks"].values():
        band(track["line"], track["closed"], track["width"] / 2.0, PGM_FREE)
    for wall in doc.get("walls", []):
        for x1, y1, x2, y2 in wall_pieces(wall):
            length = math.hypot(x2 - x1, y2 - y1)
            ux, uy = (x2 - x1) / length, (y2 - y1) / length
            nx, ny = -uy * half_t, ux * half_t
            # Extend each piece by half a thickness so corners close; door edges stay square.
            ex, ey = ux * half_t, uy * half_t
            poly([(x1 - ex + nx, y1 - ey + ny), (x2 + ex + nx, y2 + ey + ny),
                  (x2 + ex - nx, y2 + ey - ny), (x1 - ex - nx, y1 - ey - ny)], PGM_OCCUPIED)
    for cx, cy, sx, sy, yaw_deg in doc["rects"].values():
        c, s = math.cos(math.radians(yaw_deg)), math.sin(math.radians(yaw_deg))
        corners = [(cx + c * a - s * b, cy + s * a + c * b)
                   for a, b in ((sx / 2, sy / 2), (-sx / 2, sy / 2), (-sx / 2, -sy / 2), (sx / 2, -sy / 2))]
        poly(corners, PGM_OCCUPIED)
    for cx, cy, r in doc["circles"].values():
        centre = px(cx, cy)
        radius = max(int(round(r / res * SCALE)), SCALE // 2)  # at least one cell drawn
        cv2.circle(img, centre, radius, PGM_OCCUPIED, thickness=-1, lineType=cv2.LINE_8, shift=SHIFT)
    return img


def build_world(description_path, out_base):
    """Draw ``description_path`` and write ``out_base``.pgm/.yaml (atomically)."""
    doc = load_description(description_path)
    img = draw(doc)
    grid = GridMap(data=image_to_grid(img, 0, 0.65, 0.196, "trinary"),
                   resolution=float(doc["resolution"]), origin=tuple(doc["origin"]))
    try:
        return save_map(grid, out_base)
    except MapError as e:
        raise WorldDescriptionError(str(e)) from None

