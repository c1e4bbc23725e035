"""Draw a world description (walls with doors, rectangles, circles) into a map_server map.

The built-in world is kept as a readable YAML description (worlds/*.world.yaml); this
module rasterizes it with OpenCV polygons (sub-pixel precision) at the description's
resolution: unknown (205) outside the building, free (254) inside, walls and furniture
occupied (0), exactly the trinary image map_saver would write.
"""
import math

import cv2
import numpy as np
import yaml

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
    try:
        with open(path) as f:
            doc = yaml.safe_load(f)
    except OSError as e:
        raise WorldDescriptionError(f"{path}: {e}") from None
    except yaml.YAMLError as e:
        raise WorldDescriptionError(f"{path}: malformed YAML: {e}") from None
    if not isinstance(doc, dict):
        raise WorldDescriptionError(f"{path}: expected a mapping")
    for key in ("name", "resolution", "origin", "size", "building", "wall_thickness"):
        if key not in doc:
            raise WorldDescriptionError(f"{path}: missing field '{key}'")
    doc["origin"] = _num_list(doc["origin"], 3, f"{path}: origin")
    doc["size"] = _num_list(doc["size"], 2, f"{path}: size")
    doc["building"] = _num_list(doc["building"], 4, f"{path}: building")
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

    bx0, by0, bx1, by1 = doc["building"]
    poly([(bx0, by0), (bx1, by0), (bx1, by1), (bx0, by1)], PGM_FREE)
    half_t = float(doc["wall_thickness"]) / 2.0
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

