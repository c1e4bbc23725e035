"""A 2D costmap backed by numpy, the robot footprint, and the layered costmap.

Reference: costmap_2d (ROS 1 navigation): ``costmap_2d.h`` (Costmap2D: cells, world <->
map, ``updateOrigin`` for rolling windows), ``footprint.h`` (padding, inscribed and
circumscribed radii), ``layered_costmap.h`` (updateMap: every layer widens the bounds,
then every layer writes its costs into the master grid in the plugins' order) and
``layer.h`` (the small layer interface). Python shape after nav2_simple_commander's
``PyCostmap2D``: one numpy array, ``[m]`` units, out-of-bounds answered with None.

Conventions: ``data`` is (size_y, size_x) uint8, row 0 the lowest y (OccupancyGrid
order), cell (mx, my) = data[my, mx] covering [origin + m * resolution, ... + resolution).
"""
import copy
import logging
import math

import numpy as np

from .cost_values import FREE_SPACE, NO_INFORMATION


_LOG = logging.getLogger(__name__)


class CostmapError(ValueError):
    """A costmap that cannot be built: bad geometry, footprint or plugin list."""


class Costmap2D:
    """A grid of uint8 costs with its geometry.

    size_x, size_y: cells; resolution: cell edge [m]; origin_x, origin_y: world position
    [m] of the lower-left corner of cell (0, 0); default_value: the cost of a cell that
    nothing has written (NO_INFORMATION when unknown space is tracked, else FREE_SPACE).
    """

    def __init__(self, size_x, size_y, resolution, origin_x=0.0, origin_y=0.0,
                 default_value=FREE_SPACE):
        if int(size_x) <= 0 or int(size_y) <= 0:
            raise CostmapError(f"costmap size must be positive, got {size_x} x {size_y} cells")
        if not (resolution > 0 and math.isfinite(resolution)):
            raise CostmapError(f"costmap resolution must be > 0 [m], got {resolution}")
        self.resolution = float(resolution)
        self.origin_x = float(origin_x)
        self.origin_y = float(origin_y)
        self.default_value = int(default_value)
        self.data = np.full((int(size_y), int(size_x)), self.default_value, dtype=np.uint8)

    # -- geometry ---------------------------------------------------------------------
    @property
    def size_x(self):
        """Width in cells."""
        return int(self.data.shape[1])

    @property
    def size_y(self):
        """Height in cells."""
        return int(self.data.shape[0])

    @property
    def size_in_meters(self):
        """(width [m], height [m])."""
        return self.size_x * self.resolution, self.size_y * self.resolution

    def world_to_map(self, wx, wy):
        """Cell (mx, my) holding world point (wx, wy) [m], or None when off the map."""
        if not (math.isfinite(wx) and math.isfinite(wy)):
            return None
        mx = int(math.floor((wx - self.origin_x) / self.resolution))
        my = int(math.floor((wy - self.origin_y) / self.resolution))
        if 0 <= mx < self.size_x and 0 <= my < self.size_y:
            return mx, my
        return None

    def world_to_map_no_bounds(self, wx, wy):
        """Cell (mx, my) of world point (wx, wy) [m], possibly outside the grid."""
        return (int(math.floor((wx - self.origin_x) / self.resolution)),
                int(math.floor((wy - self.origin_y) / self.resolution)))

    def map_to_world(self, mx, my):
        """World (wx, wy) [m] of the centre of cell (mx, my)."""
        return (self.origin_x + (mx + 0.5) * self.resolution,
                self.origin_y + (my + 0.5) * self.resolution)

    def world_to_map_array(self, xy):
        """Vectorized world -> map: (N, 2) [m] -> (mx, my, inside) int64, int64, bool."""
        xy = np.asarray(xy, dtype=np.float64)
        mx = np.floor((xy[..., 0] - self.origin_x) / self.resolution).astype(np.int64)
        my = np.floor((xy[..., 1] - self.origin_y) / self.resolution).astype(np.int64)
        inside = (mx >= 0) & (my >= 0) & (mx < self.size_x) & (my < self.size_y)
        return mx, my, inside

    # -- cells ------------------------------------------------------------------------
    def get_cost(self, mx, my):
        """Cost (0..255) of cell (mx, my); None when off the grid."""
        if 0 <= mx < self.size_x and 0 <= my < self.size_y:
            return int(self.data[my, mx])
        return None

    def set_cost(self, mx, my, cost):
        """Write one cell; False when (mx, my) is off the grid."""
        if 0 <= mx < self.size_x and 0 <= my < self.size_y:
            self.data[my, mx] = cost
            return True
        return False

    def cost_at(self, wx, wy):
        """Cost of the cell under world point (wx, wy) [m]; None when off the map."""
        cell = self.world_to_map(wx, wy)
        return None if cell is None else int(self.data[cell[1], cell[0]])

    def copy(self):
        """An independent copy (its own cells, the same geometry)."""
        out = copy.copy(self)
        out.data = self.data.copy()
        return out

    def reset(self, window=None):
        """Set every cell (or the cells of window (x0, y0, x1, y1), ends exclusive) to default."""
        if window is None:
            self.data.fill(self.default_value)
        else:
            x0, y0, x1, y1 = window
            self.data[y0:y1, x0:x1] = self.default_value

    def clear_area(self, window, invert=False):
        """Reset cells inside window (x0, y0, x1, y1) or, with invert, all cells outside it."""
        x0, y0, x1, y1 = (int(v) for v in window)
        x0, x1 = max(0, x0), min(self.size_x, x1)
        y0, y1 = max(0, y0), min(self.size_y, y1)
        if not invert:
            if x1 > x0 and y1 > y0:
                self.data[y0:y1, x0:x1] = self.default_value
            return
        keep = self.data[y0:y1, x0:x1].copy() if (x1 > x0 and y1 > y0) else None
        self.data.fill(self.default_value)
        if keep is not None:
            self.data[y0:y1, x0:x1] = keep

    def resize_map(self, size_x, size_y, resolution, origin_x, origin_y):
        """Change the geometry; all cells become the default value."""
        self.__init__(size_x, size_y, resolution, origin_x, origin_y, self.default_value)

    def update_origin(self, new_origin_x, new_origin_y):
        """Move the grid (rolling window), keeping the data of the overlapping cells.

        As costmap_2d's updateOrigin: the move is rounded to whole cells so cells stay
        aligned; cells that enter the window get the default value.
        Returns the shift (dx, dy) in cells actually applied.
        """
        cell_dx = int(math.floor((new_origin_x - self.origin_x) / self.resolution + 0.5))
        cell_dy = int(math.floor((new_origin_y - self.origin_y) / self.resolution + 0.5))
        if cell_dx == 0 and cell_dy == 0:
            return 0, 0
        self.origin_x += cell_dx * self.resolution
        self.origin_y += cell_dy * self.resolution
        old = self.data
        new = np.full_like(old, self.default_value)
        h, w = old.shape
        # Old cell (x, y) becomes new cell (x - dx, y - dy).
        sx0, sx1 = max(0, cell_dx), min(w, w + cell_dx)
        sy0, sy1 = max(0, cell_dy), min(h, h + cell_dy)
        if sx1 > sx0 and sy1 > sy0:
            new[sy0 - cell_dy:sy1 - cell_dy, sx0 - cell_dx:sx1 - cell_dx] = old[sy0:sy1, sx0:sx1]
        self.data = new
        return cell_dx, cell_dy

    def bounds_to_window(self, bounds):
        """World bounds (min_x, min_y, max_x, max_y) [m] -> cell window (x0, y0, x1, y1).

        Clipped to the grid; ends exclusive. An empty window has x1 <= x0 or y1 <= y0.
        """
        min_x, min_y, max_x, max_y = bounds
        if not (min_x <= max_x and min_y <= max_y):
            return 0, 0, 0, 0
        res = self.resolution
        x0 = max(0, int(math.floor(max(min_x - self.origin_x, -1.0) / res))) if math.isfinite(min_x) else 0
        y0 = max(0, int(math.floor(max(min_y - self.origin_y, -1.0) / res))) if math.isfinite(min_y) else 0
        x1 = self.size_x if not math.isfinite(max_x) else \
            min(self.size_x, int(math.floor((max_x - self.origin_x) / res)) + 1)
        y1 = self.size_y if not math.isfinite(max_y) else \
            min(self.size_y, int(math.floor((max_y - self.origin_y) / res)) + 1)
        return x0, y0, max(x0, x1), max(y0, y1)


# -- footprint ---------------------------------------------------------------------------
def _sign0(v):
    return 1.0 if v > 0 else (-1.0 if v < 0 else 0.0)


def pad_footprint(polygon, padding):
    """Grow a footprint polygon (N, 2) [m] by padding [m] per axis, as costmap_2d's padFootprint."""
    poly = np.array(polygon, dtype=np.float64)
    return poly + np.vectorize(_sign0)(poly) * padding


def circle_footprint(radius, n_points=16):
    """Polygon (n_points, 2) approximating a circle of radius [m] (costmap_2d's makeFootprintFromRadius)."""
    ang = np.arange(n_points) * (2.0 * math.pi / n_points)
    return np.column_stack([radius * np.cos(ang), radius * np.sin(ang)])


def footprint_radii(polygon):
    """(inscribed [m], circumscribed [m]) radii of a footprint polygon around (0, 0).

    inscribed: shortest distance from the centre to an edge; circumscribed: farthest
    vertex (costmap_2d's calculateMinAndMaxDistances).
    """
    poly = np.asarray(polygon, dtype=np.float64)
    a, b = poly, np.roll(poly, -1, axis=0)
    ab = b - a
    denom = np.maximum((ab ** 2).sum(axis=1), 1e-18)
    t = np.clip(-(a * ab).sum(axis=1) / denom, 0.0, 1.0)
    closest = a + t[:, None] * ab
    edge_dist = np.hypot(closest[:, 0], closest[:, 1])
    vert_dist = np.hypot(poly[:, 0], poly[:, 1])
    return float(min(edge_dist.min(), vert_dist.min())), float(vert_dist.max())


def parse_footprint(value):
    """A footprint parameter ([[x, y], ...] list or its string form) -> (N, 2) array [m].

    CostmapError when it has fewer than 3 points or a point is not two finite numbers.
    """
    if isinstance(value, str):
        import yaml
        try:
            value = yaml.safe_load(value)
        except yaml.YAMLError as e:
            raise CostmapError(f"footprint string is not a list of points: {e}") from None
    try:
        poly = np.array(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise CostmapError(f"footprint must be a list of [x, y] points, got {value!r}") from None
    if poly.ndim != 2 or poly.shape[1] != 2 or poly.shape[0] < 3:
        raise CostmapError(f"footprint must have at least 3 [x, y] points, got {value!r}")
    if not np.isfinite(poly).all():
        raise CostmapError(f"footprint points must be finite, got {value!r}")
    return poly


class Footprint:
    """The robot's footprint: polygon (N, 2) [m] in the base frame, already padded.

    Build with ``Footprint.from_params(footprint=..., robot_radius=..., padding=...)``:
    a polygon takes precedence over robot_radius, as in costmap_2d.
    """

    def __init__(self, polygon, is_circle=False, radius=None, padding=0.0):
        self.polygon = np.asarray(polygon, dtype=np.float64)
        self.is_circle = bool(is_circle)
        self.padding = float(padding)  # [m] footprint_padding already added to polygon
        self.inscribed_radius, self.circumscribed_radius = footprint_radii(self.polygon)
        if is_circle:
            self.inscribed_radius = self.circumscribed_radius = float(radius)

    @classmethod
    def from_params(cls, footprint=None, robot_radius=None, padding=0.0):
        """footprint: polygon (list or string) [m] or None; robot_radius [m]; footprint_padding [m]."""
        if footprint is not None and not (isinstance(footprint, (list, tuple, str, np.ndarray))
                                          and len(footprint) == 0):
            return cls(pad_footprint(parse_footprint(footprint), padding), padding=padding)
        if robot_radius is None or not (robot_radius > 0):
            raise CostmapError(f"need a footprint polygon or robot_radius > 0, got {robot_radius!r}")
        r = float(robot_radius) + float(padding)
        return cls(circle_footprint(r), is_circle=True, radius=r, padding=padding)

    def oriented(self, x, y, yaw):
        """The polygon placed at pose (x [m], y [m], yaw [rad]) -> (N, 2) [m]."""
        c, s = math.cos(yaw), math.sin(yaw)
        return self.polygon @ np.array([[c, s], [-s, c]]) + np.array([x, y])

    def covering_circles(self, max_excess=0.01):
        """Circles that cover the footprint: (centres (K, 2) [m], radius [m]).

        A rectangle-like polygon is covered by K equal circles centred on its long axis;
        K grows until a circle sticks out of the footprint's half-width by at most
        max_excess [m]. Used by DWA's vectorized footprint check (a robot collides only
        if an obstacle lies within some circle).
        """
        if self.is_circle:
            return np.zeros((1, 2)), self.circumscribed_radius
        xs, ys = self.polygon[:, 0], self.polygon[:, 1]
        x0, x1, y0, y1 = xs.min(), xs.max(), ys.min(), ys.max()
        half_w = 0.5 * (y1 - y0)
        yc = 0.5 * (y0 + y1)
        for k in range(1, 16):
            seg = (x1 - x0) / k
            r = math.hypot(seg / 2.0, half_w)
            if r - half_w <= max_excess:
                break
        centres = np.column_stack([x0 + seg * (np.arange(k) + 0.5), np.full(k, yc)])
        return centres, r


    def grid_circles(self, cell=0.12):
        """A finer cover: circles on a grid over the footprint's bounding box.

        Returns (centres (K, 2) [m], radius [m]): the box is split into cells of at most
        cell [m] a side, one circle per cell through its corners. The axis circles of
        covering_circles are tight at the sides (max_excess) but, each as wide as the
        robot, stick out ~0.25 m past a rectangle's front and back; this cover sticks
        out ~3 cm everywhere. Either cover alone proves a pose free (DWA and
        rotate_recovery use the axis cover first, this one where it is not enough).
        """
        if self.is_circle:
            return np.zeros((1, 2)), self.circumscribed_radius
        xs, ys = self.polygon[:, 0], self.polygon[:, 1]
        x0, x1, y0, y1 = xs.min(), xs.max(), ys.min(), ys.max()
        nx = max(1, int(math.ceil((x1 - x0) / cell - 1e-9)))
        ny = max(1, int(math.ceil((y1 - y0) / cell - 1e-9)))
        dx, dy = (x1 - x0) / nx, (y1 - y0) / ny
        gx, gy = np.meshgrid(x0 + dx * (np.arange(nx) + 0.5), y0 + dy * (np.arange(ny) + 0.5))
        centres = np.column_stack([gx.ravel(), gy.ravel()])
        # Keep the cells that touch the polygon (all of them for a rectangle).
        return centres, 0.5 * math.hypot(dx, dy)


# -- layered costmap ---------------------------------------------------------------------
class Layer:
    """The costmap_2d layer interface (layer.h): one small shape for every plugin.

    update_bounds(robot_x, robot_y, robot_yaw, bounds) -> bounds: widen the world
    rectangle (min_x, min_y, max_x, max_y) [m] that this layer needs redrawn.
    update_costs(master, window): write costs into master (a Costmap2D) inside the cell
    window (x0, y0, x1, y1), ends exclusive. reset(): forget everything sensed.
    """

    def __init__(self, name):
        self.name = name
        self.enabled = True
        self.layered = None
        self.notes = []   # warnings about its parameters, logged once when it is added

    def initialize(self, layered):
        """Called once by LayeredCostmap.add_layer."""
        self.layered = layered

    def update_bounds(self, robot_x, robot_y, robot_yaw, bounds):
        return bounds

    def update_costs(self, master, window):
        pass

    def reset(self):
        pass

    def match_size(self):
        """The master grid changed size or origin; follow it."""

    def on_footprint_changed(self):
        """The footprint (and so the inscribed radius) changed."""


def expand_bounds(bounds, min_x, min_y, max_x, max_y):
    """Union of bounds (min_x, min_y, max_x, max_y) with another rectangle [m]."""
    return (min(bounds[0], min_x), min(bounds[1], min_y),
            max(bounds[2], max_x), max(bounds[3], max_y))


EMPTY_BOUNDS = (math.inf, math.inf, -math.inf, -math.inf)


class LayeredCostmap:
    """The master costmap and its layers, updated in plugin order (layered_costmap.cpp).

    master: a Costmap2D (its default value says whether unknown space is tracked);
    rolling_window: True for the local costmap, whose origin follows the robot;
    footprint: a Footprint; log: called with each warning of the costmap and its layers
    (``warn_once``), default this package's Python logger; name: put in front of them.
    """

    def __init__(self, master, footprint, rolling_window=False, log=None, name="costmap"):
        self.master = master
        self.log = log if log is not None else _LOG.warning
        self.name = name
        self._warned = set()
        self.rolling_window = bool(rolling_window)
        self.layers = []
        self.footprint = footprint
        self.last_bounds = EMPTY_BOUNDS
        self.last_window = (0, 0, 0, 0)
        self.robot_pose = None
        self.version = 0  # incremented at every update_map (planners cache on it)
        self.force_full_update = False  # set after clearing layers: redraw the whole master

    @classmethod
    def from_plugins(cls, plugins, params, master, footprint, rolling_window=False):
        """Build from a costmap_2d ``plugins`` list [{name, type}, ...].

        params: {layer name: {parameter: value}} (the costmap's YAML namespace);
        CostmapError naming the plugin for an unknown type or a malformed entry.
        """
        return cls(master, footprint, rolling_window).add_plugins(plugins, params)

    def add_plugins(self, plugins, params):
        """Add the layers of a costmap_2d ``plugins`` list, in order; returns self."""
        from . import layers as layer_mod
        if not isinstance(plugins, (list, tuple)):
            raise CostmapError(f"plugins must be a list of {{name, type}}, got {plugins!r}")
        for i, p in enumerate(plugins):
            if not isinstance(p, dict) or "name" not in p or "type" not in p:
                raise CostmapError(f"plugins[{i}] must have 'name' and 'type', got {p!r}")
            self.add_layer(layer_mod.make_layer(p["type"], p["name"], params.get(p["name"], {})))
        return self

    def warn_once(self, message):
        """Log a warning, prefixed with the costmap's name, the first time it is given."""
        if message not in self._warned:
            self._warned.add(message)
            self.log(f"{self.name}: {message}")

    @property
    def inscribed_radius(self):
        """[m]"""
        return self.footprint.inscribed_radius

    @property
    def circumscribed_radius(self):
        """[m]"""
        return self.footprint.circumscribed_radius

    @property
    def track_unknown_space(self):
        return self.master.default_value == NO_INFORMATION

    def add_layer(self, layer):
        """Append a layer (plugins are drawn in the order they are added)."""
        if any(l.name == layer.name for l in self.layers):
            raise CostmapError(f"two costmap layers are named '{layer.name}'")
        layer.initialize(self)
        self.layers.append(layer)
        for note in layer.notes:
            self.warn_once(note)
        return layer

    def layer(self, name):
        """The layer called name; CostmapError listing the layers otherwise."""
        for l in self.layers:
            if l.name == name:
                return l
        raise CostmapError(f"no costmap layer '{name}' (layers: {[l.name for l in self.layers]})")

    def set_footprint(self, footprint):
        """Change the footprint; layers that depend on it (inflation) are told."""
        self.footprint = footprint
        for l in self.layers:
            l.on_footprint_changed()

    def resize_map(self, size_x, size_y, resolution, origin_x, origin_y):
        """Resize the master grid and every layer that keeps its own grid."""
        self.master.resize_map(size_x, size_y, resolution, origin_x, origin_y)
        for l in self.layers:
            l.match_size()

    def update_map(self, robot_x, robot_y, robot_yaw):
        """One costmap update at robot pose (x [m], y [m], yaw [rad]) in the costmap frame.

        Rolling windows are recentred on the robot first. Returns the cell window redrawn.
        """
        self.robot_pose = (robot_x, robot_y, robot_yaw)
        if self.rolling_window:
            w, h = self.master.size_in_meters
            self.master.update_origin(robot_x - w / 2.0, robot_y - h / 2.0)
            for l in self.layers:
                l.match_size()
        bounds = EMPTY_BOUNDS
        for l in self.layers:
            if l.enabled:
                bounds = l.update_bounds(robot_x, robot_y, robot_yaw, bounds)
        if self.rolling_window or self.force_full_update:
            # A rolled window must be redrawn whole (shifted cells carry stale inflation),
            # and so must a costmap whose layers were cleared.
            self.force_full_update = False
            ox, oy = self.master.origin_x, self.master.origin_y
            w, h = self.master.size_in_meters
            bounds = expand_bounds(bounds, ox, oy, ox + w, oy + h)
        window = self.master.bounds_to_window(bounds)
        self.last_bounds, self.last_window = bounds, window
        x0, y0, x1, y1 = window
        if x1 > x0 and y1 > y0:
            self.master.reset(window)
            for l in self.layers:
                if l.enabled:
                    l.update_costs(self.master, window)
        self.version += 1
        return window

    def reset(self):
        """Reset the master grid and every layer (costmap_2d's resetLayers)."""
        self.master.reset()
        for l in self.layers:
            l.reset()
        self.version += 1


class CostmapPublisher:
    """What a costmap sends at each publish cycle: costmap_2d's Costmap2DPublisher
    (costmap_2d_publisher.cpp) without ROS.

    The whole grid (on ``~costmap``) the first time, whenever the grid's size, resolution
    or origin changed since the whole grid was last sent (a rolling window moves its
    origin every cycle), or every time with always_send_full_costmap; otherwise the cell
    window redrawn since the last cycle (the union of update_map's windows), as an
    OccupancyGridUpdate on ``~costmap_updates``; nothing when no cell was redrawn. A new
    subscriber is sent the whole grid at once, by the caller, to it alone.
    """

    def __init__(self, always_send_full_costmap=False):
        self.always_full = bool(always_send_full_costmap)
        self.sent_geometry = None   # (size_x, size_y, resolution, origin_x, origin_y) of the last whole grid
        self.window = None          # (x0, y0, x1, y1) redrawn since the last cycle, x1 and y1 excluded

    @staticmethod
    def geometry(master):
        return (master.size_x, master.size_y, master.resolution, master.origin_x, master.origin_y)

    def add_window(self, window):
        """Count a redrawn cell window (x0, y0, x1, y1) in the next update."""
        x0, y0, x1, y1 = (int(v) for v in window)
        if x1 <= x0 or y1 <= y0:
            return
        if self.window is not None:
            a0, b0, a1, b1 = self.window
            x0, y0, x1, y1 = min(x0, a0), min(y0, b0), max(x1, a1), max(y1, b1)
        self.window = (x0, y0, x1, y1)

    def next(self, master):
        """("full", None), ("update", (x0, y0, x1, y1)) or None for this cycle."""
        geometry = self.geometry(master)
        if self.always_full or geometry != self.sent_geometry:
            self.sent_geometry, out = geometry, ("full", None)
        elif self.window is not None:
            x0, y0, x1, y1 = self.window
            window = (max(0, x0), max(0, y0), min(master.size_x, x1), min(master.size_y, y1))
            out = ("update", window) if window[2] > window[0] and window[3] > window[1] else None
        else:
            out = None
        self.window = None
        return out
