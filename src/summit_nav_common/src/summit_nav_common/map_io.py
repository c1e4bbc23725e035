"""Occupancy-grid map files with ROS map_server's exact semantics.

Reads a map YAML + image (PGM, PNG, BMP, ...) into the int8 cell values of a
nav_msgs/OccupancyGrid, and writes a map as map_saver does (trinary PGM + YAML).

Reference: ROS 1 map_server, ``image_loader.cpp`` (loadMapFromFile) and
``map_saver.cpp``; YAML keys documented at wiki.ros.org/map_server.

The one map I/O of the workspace: the simulator loads its worlds with it, and the
mapping package's map_server and map_saver read and write with it.

Conventions: ``data`` is a (height, width) int8 array in OccupancyGrid order, row 0 the
*lowest* row of the image (map_server flips the image so cell (0, 0) is the lower-left
corner). Values: 100 occupied, 0 free, -1 unknown, 1..99 in ``scale`` mode.
"""
import math
import os
from dataclasses import dataclass, field

import numpy as np
import yaml

from summit_nav_common.files import write_atomic

OCCUPIED = 100  # OccupancyGrid value of a lethal cell
FREE = 0
UNKNOWN = -1
MODES = ("trinary", "scale", "raw")

# map_saver's pixel values for the trinary PGM it writes.
PGM_FREE = 254
PGM_OCCUPIED = 0
PGM_UNKNOWN = 205
# map_saver's default thresholds on OccupancyGrid values [0..100].
SAVER_OCCUPIED_THRESHOLD = 65
SAVER_FREE_THRESHOLD = 25
# What map_saver writes into the YAML (and so what the saved map means).
SAVER_OCCUPIED_THRESH = 0.65
SAVER_FREE_THRESH = 0.196


class MapError(ValueError):
    """A map file that cannot be loaded or saved; the message names the file and field."""


@dataclass
class GridMap:
    """An occupancy grid with its geometry.

    data: (height, width) int8, OccupancyGrid values, row 0 = lowest y.
    resolution: cell edge [m].
    origin: (x [m], y [m], yaw [rad]) of the lower-left corner of cell (0, 0).
    """

    data: np.ndarray
    resolution: float
    origin: tuple = (0.0, 0.0, 0.0)
    # Extra facts from the YAML that loaded it (for reporting); not part of the grid.
    source: dict = field(default_factory=dict)

    @property
    def width(self):
        """Number of columns (cells along x)."""
        return int(self.data.shape[1])

    @property
    def height(self):
        """Number of rows (cells along y)."""
        return int(self.data.shape[0])

    def world_to_cell(self, x, y):
        """Cell (col, row) holding world point (x, y) [m], or None when off the map.

        Honours the origin's yaw, as map_server's origin does.
        """
        ox, oy, oyaw = self.origin
        dx, dy = x - ox, y - oy
        c, s = math.cos(oyaw), math.sin(oyaw)
        mx, my = c * dx + s * dy, -s * dx + c * dy
        col = int(math.floor(mx / self.resolution))
        row = int(math.floor(my / self.resolution))
        if 0 <= col < self.width and 0 <= row < self.height:
            return col, row
        return None

    def cell_to_world(self, col, row):
        """World (x, y) [m] of the centre of cell (col, row)."""
        ox, oy, oyaw = self.origin
        mx, my = (col + 0.5) * self.resolution, (row + 0.5) * self.resolution
        c, s = math.cos(oyaw), math.sin(oyaw)
        return ox + c * mx - s * my, oy + s * mx + c * my


def _require(doc, key, path, kind):
    if key not in doc:
        raise MapError(f"{path}: the map YAML has no '{key}' field")
    value = doc[key]
    try:
        if kind is float:
            value = float(value)
            if not math.isfinite(value):
                raise ValueError
        elif kind is int:
            if isinstance(value, bool):
                value = int(value)
            elif float(value) != int(float(value)):
                raise ValueError
            value = int(float(value))
        elif kind is str:
            if not isinstance(value, str) or not value:
                raise ValueError
    except (TypeError, ValueError):
        raise MapError(f"{path}: field '{key}' is invalid: {value!r}") from None
    return value


def read_map_yaml(path):
    """Parse and validate a map_server YAML; returns a dict with absolute image path.

    Raises MapError naming the file and the field for: a missing file, malformed YAML,
    a missing or invalid field, an unknown mode, thresholds out of [0, 1] or in the
    wrong order, a non-positive resolution, or an image that does not exist.
    """
    if not os.path.isfile(path):
        raise MapError(f"{path}: map YAML does not exist")
    try:
        with open(path) as f:
            doc = yaml.safe_load(f)
    except yaml.YAMLError as e:
        raise MapError(f"{path}: malformed YAML: {e}") from None
    if not isinstance(doc, dict):
        raise MapError(f"{path}: malformed map YAML: expected a mapping of fields")
    image = _require(doc, "image", path, str)
    resolution = _require(doc, "resolution", path, float)
    if resolution <= 0:
        raise MapError(f"{path}: field 'resolution' must be > 0, got {resolution}")
    origin = doc.get("origin")
    if origin is None:
        raise MapError(f"{path}: the map YAML has no 'origin' field")
    try:
        origin = tuple(float(v) for v in origin)
        if len(origin) != 3 or not all(math.isfinite(v) for v in origin):
            raise ValueError
    except (TypeError, ValueError):
        raise MapError(f"{path}: field 'origin' must be [x, y, yaw], got {doc['origin']!r}") from None
    negate = _require(doc, "negate", path, int)
    if negate not in (0, 1):
        raise MapError(f"{path}: field 'negate' must be 0 or 1, got {negate}")
    occ = _require(doc, "occupied_thresh", path, float)
    free = _require(doc, "free_thresh", path, float)
    for key, v in (("occupied_thresh", occ), ("free_thresh", free)):
        if not 0.0 <= v <= 1.0:
            raise MapError(f"{path}: field '{key}' must be within [0, 1], got {v}")
    if free > occ:
        raise MapError(f"{path}: field 'free_thresh' ({free}) is above 'occupied_thresh' ({occ})")
    mode = doc.get("mode", "trinary")
    if mode not in MODES:
        raise MapError(f"{path}: field 'mode' must be one of {', '.join(MODES)}, got {mode!r}")
    # The simulator's own field (map_server ignores fields it does not know): unknown
    # cells farther than this [m] from every free cell are solid (see summit_xl_sim.world).
    unknown_solid_beyond = doc.get("unknown_solid_beyond")
    if unknown_solid_beyond is not None:
        if isinstance(unknown_solid_beyond, bool) or not isinstance(unknown_solid_beyond, (int, float)) \
                or not math.isfinite(unknown_solid_beyond) or unknown_solid_beyond < 0:
            raise MapError(f"{path}: field 'unknown_solid_beyond' must be a distance >= 0 [m], "
                           f"got {unknown_solid_beyond!r}")
        unknown_solid_beyond = float(unknown_solid_beyond)
    if not os.path.isabs(image):
        image = os.path.join(os.path.dirname(os.path.abspath(path)), image)
    if not os.path.isfile(image):
        raise MapError(f"{path}: field 'image': image file {image} does not exist")
    return {"image": image, "resolution": resolution, "origin": origin, "negate": negate,
            "occupied_thresh": occ, "free_thresh": free, "mode": mode,
            "unknown_solid_beyond": unknown_solid_beyond}


def image_to_grid(pixels, negate, occupied_thresh, free_thresh, mode):
    """Pixel array (rows top-down, as read) -> (height, width) int8 OccupancyGrid values.

    Exactly map_server's loop, vectorized: colour channels averaged (alpha averaged in
    too in trinary mode, as map_server does), optional negate, occ = (255 - v) / 255,
    thresholds, scale mode's 1 + 98 * ratio (truncated toward zero as C's int cast),
    raw mode's plain value, and the rows flipped so row 0 is the lowest. Scale mode marks
    a cell between the thresholds unknown when its pixel's *last* byte is 0: map_server
    reads that byte as alpha whatever the image (on an RGB image, blue; on a BMP, red).
    pixels: as read_image gives them.
    """
    img = np.asarray(pixels)
    if img.dtype != np.uint8:
        raise MapError(f"image has {img.dtype} pixels; map_server reads 8-bit images")
    if img.ndim == 2:
        img = img[:, :, None]
    n_channels = img.shape[2]
    has_alpha = n_channels in (2, 4)
    avg_channels = n_channels if (mode == "trinary" or not has_alpha) else n_channels - 1
    color = img[:, :, :avg_channels].astype(np.float64).sum(axis=2) / avg_channels
    alpha = img[:, :, -1].astype(np.float64) if n_channels > 1 else np.full(color.shape, 1.0)
    if negate:
        color = 255.0 - color
    if mode == "raw":
        value = np.trunc(color).astype(np.int32)
    else:
        occ = (255.0 - color) / 255.0
        value = np.full(color.shape, UNKNOWN, np.int32)
        scaled = (mode == "scale") & (alpha >= 1.0)
        if mode == "scale":
            ratio = (occ - free_thresh) / max(occupied_thresh - free_thresh, 1e-12)
            mid = np.trunc(1.0 + 98.0 * ratio).astype(np.int32)
            value = np.where(scaled, mid, value)
        value = np.where(occ < free_thresh, FREE, value)
        value = np.where(occ > occupied_thresh, OCCUPIED, value)
    # int8 wrap-around for raw values > 127, as the C++ assignment into int8 data does.
    return value[::-1].astype(np.uint8).view(np.int8).copy()


# Files whose colour pixels SDL_image keeps in the file's blue-first byte order.
BGR_FORMATS = ("BMP", "TGA")


def read_image(path):
    """An image file's pixels as map_server sees them through SDL_image: uint8, (H, W)
    for one byte per pixel, else (H, W, C) in the surface's byte order.

    Checked against the real map_server (noetic) on PNG, BMP, PGM/PPM and JPEG files
    (docs/map_server.md): a palette image gives its palette *indices* (SDL keeps the
    8-bit surface and map_server reads its bytes), a 16-bit image the high byte of each
    value, grey with alpha four bytes (grey three times, then alpha), bilevel 0 / 255;
    BMP and TGA colours come blue first. MapError for a file that is not an image or a
    pixel format map_server cannot read.
    """
    from PIL import Image   # here: nodes that only hold maps (amcl, move_base) do not load Pillow
    try:
        with Image.open(path) as im:
            im.load()
            fmt, mode = im.format, im.mode
            if mode in ("L", "P"):
                return np.array(im, dtype=np.uint8)
            if mode in ("I", "I;16", "I;16B", "I;16L"):  # 16-bit grey (PNG's comes as "I")
                values = np.array(im)
                if values.min() < 0 or values.max() > 65535:
                    raise MapError(f"{path}: {mode} pixels beyond 16 bits; "
                                   f"map_server reads 8- and 16-bit images")
                return (values.astype(np.uint32) >> 8).astype(np.uint8)
            if mode == "1":
                return np.array(im.convert("L"), dtype=np.uint8)
            if mode in ("LA", "La", "PA", "RGBA", "RGBa"):
                pixels = np.array(im.convert("RGBA"), dtype=np.uint8)
            elif mode in ("RGB", "RGBX", "CMYK", "YCbCr", "LAB", "HSV"):
                pixels = np.array(im.convert("RGB"), dtype=np.uint8)
            else:
                raise MapError(f"{path}: {mode} pixels; map_server reads 8- and 16-bit grey, "
                               f"palette, RGB and RGBA images")
    except MapError:
        raise
    except (OSError, ValueError, Image.DecompressionBombError) as e:
        raise MapError(f"cannot read {path} as an image: {e}") from None
    if fmt in BGR_FORMATS:
        pixels[:, :, :3] = pixels[:, :, 2::-1].copy()
    return pixels


def _grid_from_image(meta, where):
    """GridMap from the checked fields of a map (read_map_yaml's dict); errors start with where."""
    try:
        pixels = read_image(meta["image"])
        data = image_to_grid(pixels, meta["negate"], meta["occupied_thresh"],
                             meta["free_thresh"], meta["mode"])
    except MapError as e:
        raise MapError(f"{where}: {e}") from None
    return GridMap(data=data, resolution=meta["resolution"], origin=meta["origin"], source=meta)


def load_map(yaml_path):
    """Load a map_server YAML + image into a GridMap (see image_to_grid)."""
    meta = read_map_yaml(yaml_path)
    return _grid_from_image(meta, f"{yaml_path}: field 'image'")


# map_server's deprecated form ``map_server IMAGE RESOLUTION`` (loadMapFromParams): the
# fields a YAML would give, at these values (negate and the thresholds may be changed by
# the node's private parameters of the same names).
DEPRECATED_NEGATE = 0
DEPRECATED_OCCUPIED_THRESH = 0.65
DEPRECATED_FREE_THRESH = 0.196
DEPRECATED_ORIGIN = (0.0, 0.0, 0.0)  # (x [m], y [m], yaw [rad])
DEPRECATED_MODE = "trinary"


def load_image_map(image_path, resolution, negate=DEPRECATED_NEGATE,
                   occupied_thresh=DEPRECATED_OCCUPIED_THRESH, free_thresh=DEPRECATED_FREE_THRESH):
    """Load an image with no YAML, as ``map_server IMAGE RESOLUTION`` does.

    resolution [m/cell] > 0; origin (0, 0, 0), trinary mode; negate and the thresholds
    as in a map YAML. MapError naming the argument for a missing or unreadable image, a
    resolution that is not a positive finite number, or bad thresholds.
    """
    if isinstance(resolution, bool) or not isinstance(resolution, (int, float)) \
            or not math.isfinite(resolution) or resolution <= 0:
        raise MapError(f"resolution must be a positive number [m/cell], got {resolution!r}")
    if negate not in (0, 1) or isinstance(negate, bool):
        raise MapError(f"negate must be 0 or 1, got {negate!r}")
    for key, v in (("occupied_thresh", occupied_thresh), ("free_thresh", free_thresh)):
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not 0.0 <= v <= 1.0:
            raise MapError(f"{key} must be within [0, 1], got {v!r}")
    if free_thresh > occupied_thresh:
        raise MapError(f"free_thresh ({free_thresh}) is above occupied_thresh ({occupied_thresh})")
    if not os.path.isfile(image_path):
        raise MapError(f"{image_path}: image file does not exist")
    meta = {"image": os.path.abspath(image_path), "resolution": float(resolution),
            "origin": DEPRECATED_ORIGIN, "negate": int(negate), "occupied_thresh": float(occupied_thresh),
            "free_thresh": float(free_thresh), "mode": DEPRECATED_MODE, "unknown_solid_beyond": None}
    return _grid_from_image(meta, f"{image_path}")


def grid_to_pgm(data, occupied_threshold=SAVER_OCCUPIED_THRESHOLD, free_threshold=SAVER_FREE_THRESHOLD):
    """OccupancyGrid values -> map_saver's trinary pixels (rows top-down, uint8)."""
    data = np.asarray(data, dtype=np.int16)
    img = np.full(data.shape, PGM_UNKNOWN, np.uint8)
    img[(data >= 0) & (data <= free_threshold)] = PGM_FREE
    img[data >= occupied_threshold] = PGM_OCCUPIED
    return img[::-1].copy()


def save_map(grid, base_path, occupied_threshold=SAVER_OCCUPIED_THRESHOLD,
             free_threshold=SAVER_FREE_THRESHOLD):
    """Write ``<base_path>.pgm`` and ``<base_path>.yaml`` as ROS map_saver does.

    Both files are written atomically (temporary file + rename), the image first, so a
    failure leaves any earlier map with this name intact. Raises MapError naming the path
    when the folder does not exist or cannot be written.
    Returns (pgm_path, yaml_path).
    """
    folder = os.path.dirname(os.path.abspath(base_path))
    if not os.path.isdir(folder):
        raise MapError(f"{base_path}: folder {folder} does not exist")
    if not os.access(folder, os.W_OK):
        raise MapError(f"{base_path}: folder {folder} is not writable")
    pgm_path, yaml_path = base_path + ".pgm", base_path + ".yaml"
    img = grid_to_pgm(grid.data, occupied_threshold, free_threshold)
    header = (f"P5\n# CREATOR: map_saver.cpp {grid.resolution:.3f} m/pix\n"
              f"{img.shape[1]} {img.shape[0]}\n255\n").encode()
    ox, oy, oyaw = grid.origin
    text = (f"image: {os.path.basename(pgm_path)}\nresolution: {grid.resolution:f}\n"
            f"origin: [{ox:f}, {oy:f}, {oyaw:f}]\nnegate: 0\n"
            f"occupied_thresh: {SAVER_OCCUPIED_THRESH}\nfree_thresh: {SAVER_FREE_THRESH}\n\n")
    try:
        write_atomic(pgm_path, header + img.tobytes())
        write_atomic(yaml_path, text)
    except OSError as e:
        raise MapError(f"{base_path}: cannot write map: {e}") from None
    return pgm_path, yaml_path
