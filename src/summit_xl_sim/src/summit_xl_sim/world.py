"""The simulated world: static walls from a map_server map, plus boxes added at run time.

A world is any map_server YAML + image; its occupied cells (value 100 in trinary or
scale mode, >= 65 in raw mode) are walls, and so is the map's outermost ring of cells (a
robot cannot leave the map, and its laser sees where it would stop). Unknown cells are
open space: the laser passes through them, as it would through the unexplored parts of a
real building's map.

A world YAML may say ``unknown_solid_beyond: D`` (a field of ours; map_server ignores
it): its unknown cells farther than D [m] from every free cell are then solid too. A
real map's walls are dashed where the laser saw through them (willow-full's are), so with
all unknown cells open the building leaks into the unknown outside through every gap: a
robot exploring it drives out and on across the whole map rectangle, to its edge. The
unknown outside and the unseen insides of furniture lie far from free cells and turn
solid; the laser shadows inside the rooms (unknown fingers, narrow) stay open, and a band
of D behind a gap is too narrow for the robot. D = 0: every unknown cell is solid.

Geometry helpers answer in metres in the world frame, which is the frame of the map's
origin (the ``map`` frame of the navigation stack when that map is loaded).
"""
import math

import numpy as np

from summit_nav_common import raycast
from summit_nav_common.distance import distance_field
from summit_nav_common.map_io import FREE, OCCUPIED, UNKNOWN, load_map

RAW_WALL_VALUE = 65  # raw mode: cell values are 0..255 occupancy in percent-like units


class WorldError(ValueError):
    """A world that cannot be loaded, or a pose that is not free in it."""


def oriented_rect_corners(cx, cy, yaw, half_length, half_width):
    """The 4 corners (4, 2) [m] of a rectangle centred at (cx, cy) with heading yaw."""
    c, s = math.cos(yaw), math.sin(yaw)
    local = np.array([[half_length, half_width], [-half_length, half_width],
                      [-half_length, -half_width], [half_length, -half_width]])
    return local @ np.array([[c, s], [-s, c]]) + np.array([cx, cy])


def rects_overlap(a, b):
    """Separating-axis test for two oriented rectangles given as (cx, cy, yaw, hl, hw)."""
    ca, cb = oriented_rect_corners(*a), oriented_rect_corners(*b)
    for yaw in (a[2], b[2]):
        for axis in ((math.cos(yaw), math.sin(yaw)), (-math.sin(yaw), math.cos(yaw))):
            pa, pb = ca @ axis, cb @ axis
            if pa.max() < pb.min() or pb.max() < pa.min():
                return False
    return True


class World:
    """Static occupancy grid + dynamic boxes, with ray casting and collision queries.

    grid: a map_io.GridMap. Boxes are oriented rectangles (cx, cy, yaw, half_length,
    half_width) [m, m, rad, m, m] keyed by name.
    """

    def __init__(self, grid, name="world"):
        self.grid = grid
        self.name = name
        if grid.source.get("mode") == "raw":
            walls = grid.data.view(np.uint8) >= RAW_WALL_VALUE
        else:
            walls = grid.data == OCCUPIED
        beyond = grid.source.get("unknown_solid_beyond")
        if beyond is not None:
            to_free = distance_field(grid.data == FREE) * float(grid.resolution)  # [m], cell centres
            walls = walls | ((grid.data == UNKNOWN) & (to_free > beyond))
        # The map's outermost cells are walls: the robot cannot leave the map, so the laser
        # must see where it stops (where free cells reach the edge, as on willow-full's
        # west side, a robot drove into an edge its laser did not show).
        walls[[0, -1], :] = True      # walls is a new array here (comparisons above)
        walls[:, [0, -1]] = True
        self.walls = np.ascontiguousarray(walls)
        self.dist = distance_field(self.walls)  # [cells]
        self.resolution = float(grid.resolution)
        self.origin = tuple(float(v) for v in grid.origin)
        self._cos_o, self._sin_o = math.cos(self.origin[2]), math.sin(self.origin[2])
        self.boxes = {}

    @classmethod
    def from_yaml(cls, path):
        """Load a world from a map_server YAML (errors name the file and field)."""
        try:
            return cls(load_map(path), name=path)
        except ValueError as e:
            raise WorldError(str(e)) from None

    # -- frames -----------------------------------------------------------------------
    def to_grid(self, x, y):
        """World point [m] -> continuous grid coordinates [cells]."""
        dx, dy = x - self.origin[0], y - self.origin[1]
        gx = (self._cos_o * dx + self._sin_o * dy) / self.resolution
        gy = (-self._sin_o * dx + self._cos_o * dy) / self.resolution
        return gx, gy

    def bounds(self):
        """(xmin, ymin, xmax, ymax) [m] of the map's axis-aligned extent (origin yaw 0)."""
        ox, oy, _ = self.origin
        return (ox, oy, ox + self.grid.width * self.resolution,
                oy + self.grid.height * self.resolution)

    def on_map(self, x, y):
        """True when world point (x, y) [m] lies on the grid."""
        gx, gy = self.to_grid(x, y)
        return 0 <= gx < self.grid.width and 0 <= gy < self.grid.height

    # -- boxes ------------------------------------------------------------------------
    def add_box(self, name, cx, cy, yaw, size_x, size_y):
        """Add (or move) box ``name`` [m, rad]; sizes are full edge lengths [m]."""
        if not name:
            raise WorldError("a box needs a non-empty name")
        vals = (cx, cy, yaw, size_x, size_y)
        if not all(math.isfinite(v) for v in vals):
            raise WorldError(f"box '{name}': pose and size must be finite, got {vals}")
        if size_x <= 0 or size_y <= 0:
            raise WorldError(f"box '{name}': sizes must be > 0, got {size_x} x {size_y}")
        if not self.on_map(cx, cy):
            raise WorldError(f"box '{name}': centre ({cx:.2f}, {cy:.2f}) is off the map")
        self.boxes[name] = (float(cx), float(cy), float(yaw), size_x / 2.0, size_y / 2.0)

    def remove_box(self, name):
        """Remove box ``name``; WorldError when there is no such box."""
        if name not in self.boxes:
            known = ", ".join(sorted(self.boxes)) or "none"
            raise WorldError(f"no box named '{name}' (boxes: {known})")
        del self.boxes[name]

    # -- queries ----------------------------------------------------------------------
    def clearance(self, x, y):
        """Distance [m] from (x, y) to the nearest wall cell centre; 0 off the map."""
        gx, gy = self.to_grid(x, y)
        ix, iy = int(math.floor(gx)), int(math.floor(gy))
        if not (0 <= ix < self.grid.width and 0 <= iy < self.grid.height):
            return 0.0
        return float(self.dist[iy, ix]) * self.resolution

    def points_hit_walls(self, pts):
        """True when any world point of (N, 2) pts [m] is in a wall cell or off the map."""
        pts = np.asarray(pts, dtype=np.float64)
        dx, dy = pts[:, 0] - self.origin[0], pts[:, 1] - self.origin[1]
        gx = np.floor((self._cos_o * dx + self._sin_o * dy) / self.resolution).astype(np.int64)
        gy = np.floor((-self._sin_o * dx + self._cos_o * dy) / self.resolution).astype(np.int64)
        off = (gx < 0) | (gy < 0) | (gx >= self.grid.width) | (gy >= self.grid.height)
        if off.any():
            return True
        return bool(self.walls[gy, gx].any())

    def cast(self, x, y, angles, range_max, extra_rects=()):
        """Ranges [m] from world point (x, y) along world ``angles`` [rad].

        Walls by exact grid ray casting; boxes and ``extra_rects`` (other robots, as
        (cx, cy, yaw, half_length, half_width)) analytically. Beams that hit nothing
        within range_max, or leave the map, return range_max exactly (the caller
        decides how to report a no-return).
        """
        gx, gy = self.to_grid(x, y)
        tmax = range_max / self.resolution
        ranges = raycast.cast_rays(self.walls, self.dist, gx, gy,
                                   np.asarray(angles) - self.origin[2], tmax)
        ranges *= self.resolution
        rects = list(self.boxes.values()) + list(extra_rects)
        if rects:
            ranges = np.minimum(ranges, raycast.rect_ray_distances(x, y, angles, rects, range_max))
        return ranges

    def cast_hits(self, x, y, angles, range_max, extra_rects=()):
        """cast, and the |cos| of each beam's incidence angle on the surface it hits.

        Returns (ranges [m], cos_incidence), both (n_beams,). Walls: the normal of the
        grid cell edge the beam stops at (raycast.grid_hit_cos_incidence); boxes and
        ``extra_rects``: the normal of the rectangle face. cos_incidence is 1 for beams
        that hit nothing.
        """
        gx, gy = self.to_grid(x, y)
        tmax = range_max / self.resolution
        grid_angles = np.asarray(angles, dtype=np.float64) - self.origin[2]
        cells = raycast.cast_rays(self.walls, self.dist, gx, gy, grid_angles, tmax)
        cos_inc = raycast.grid_hit_cos_incidence(gx, gy, grid_angles, cells)
        ranges = cells * self.resolution
        rects = list(self.boxes.values()) + list(extra_rects)
        if rects:
            rect_t, rect_cos = raycast.rect_ray_hits(x, y, angles, rects, range_max)
            nearer = rect_t < ranges
            ranges = np.where(nearer, rect_t, ranges)
            cos_inc = np.where(nearer, rect_cos, cos_inc)
        cos_inc[ranges >= range_max] = 1.0
        return ranges, cos_inc
