"""costmap_2d's layers: static map, obstacles from the laser (and its voxel variant), inflation.

Reference: costmap_2d plugins ``static_layer.cpp`` (interpretValue: lethal threshold,
unknown handling, trinary costs), ``obstacle_layer.cpp`` (marking within obstacle_range,
ray-traced clearing within raytrace_range, inf_is_valid, combination_method, footprint
clearing, the sensor height tests of ``observation_buffer.cpp``), ``voxel_layer.cpp``
(its height band, for planar lasers) and ``inflation_layer.cpp`` (the exponential cost
decay); documentation at wiki.ros.org/costmap_2d/hydro/{staticmap,obstacles,inflation}.

Each layer has the small interface of ``costmap.Layer`` and is chosen by the plugin
type string of a costmap_2d YAML (``make_layer``). Everything is vectorized: clearing
traces all rays at once (a vectorized walk along the exact rays, two samples per
cell; ``ray_cells`` is the workspace's Bresenham walk, summit_nav_common.line_cells) and inflation is one exact distance transform (``grid_kernels.distance_transform``, OpenCV's to the bit).
"""
import dataclasses
import math
from dataclasses import dataclass

import numpy as np
from summit_nav_common.grid_kernels import distance_transform, fill_rays
from summit_nav_common.line_cells import line_cells, line_cells_reference

from .cost_values import (FREE_SPACE, INSCRIBED_INFLATED_OBSTACLE, LETHAL_OBSTACLE,
                          NO_INFORMATION)
from .costmap import CostmapError, Costmap2D, Layer, expand_bounds
from .param_reader import BOOL, FLOAT, STR, WARNING, Field, Kind, Note, Schema

# Plugin type strings (costmap_2d YAML) and the short names some configs use.
STATIC_TYPES = ("costmap_2d::StaticLayer",)
OBSTACLE_TYPES = ("costmap_2d::ObstacleLayer",)
VOXEL_TYPES = ("costmap_2d::VoxelLayer",)
INFLATION_TYPES = ("costmap_2d::InflationLayer",)


def _read(schema, params, name, what):
    """schema.read of a layer's namespace: errors name the layer (CostmapError), notes say
    what it is ("static layer 'name'")."""
    return schema.read(params, name, f"{what} layer '{name}'", error=CostmapError)


SPACED_NAMES = Kind("a space-separated string", STR.check)    # observation_sources' form
# costmap_2d's voxel grid packs a column into 16 bits: at most 16 voxels
Z_VOXELS = Kind("an integer in [0, 16]", lambda v: _whole_in(v, 0, 16))


def _whole_in(v, lo, hi):
    v = FLOAT.check(v)
    if v != int(v) or not lo <= v <= hi:
        raise ValueError("")
    return int(v)


# ---------------------------------------------------------------------------------------
class StaticLayer(Layer):
    """The map from map_server as costs (costmap_2d::StaticLayer).

    Parameters (costmap_2d names): track_unknown_space (true: unknown -> NO_INFORMATION,
    false: unknown -> FREE_SPACE), use_maximum (false: overwrite the master; true: max),
    lethal_cost_threshold (OccupancyGrid value >= this -> LETHAL), unknown_cost_value
    (the OccupancyGrid value that means unknown, -1), trinary_costmap (true: other values
    -> FREE; false: scaled 0..LETHAL), map_topic / first_map_only / subscribe_to_updates
    (read by the node), enabled.
    """

    SCHEMA = Schema([
        Field("enabled", BOOL, True), Field("map_topic", STR, "map"),
        Field("first_map_only", BOOL, False), Field("subscribe_to_updates", BOOL, False),
        Field("track_unknown_space", BOOL, True), Field("use_maximum", BOOL, False),
        Field("lethal_cost_threshold", FLOAT, 100, lo=0), Field("unknown_cost_value", FLOAT, -1),
        Field("trinary_costmap", BOOL, True)])
    PARAMS = tuple(SCHEMA.fields)

    def __init__(self, name, params=None):
        super().__init__(name)
        r = _read(self.SCHEMA, params, name, "static")
        self.notes += r.notes
        vars(self).update(r.values)   # each parameter is the attribute of its name
        self.lethal_cost_threshold = int(self.lethal_cost_threshold)
        self.unknown_cost_value = int(self.unknown_cost_value)
        self.grid = None          # Costmap2D of static costs
        self._dirty = False

    def interpret(self, occupancy):
        """OccupancyGrid values (int8 array) -> costs (uint8 array), costmap_2d's interpretValue."""
        value = np.asarray(occupancy).astype(np.int16) & 0xFF   # OccupancyGrid as unsigned char
        unknown = (self.unknown_cost_value & 0xFF)
        out = np.empty(value.shape, dtype=np.uint8)
        lethal = value >= self.lethal_cost_threshold
        if self.trinary_costmap:
            out[...] = FREE_SPACE
        else:
            out[...] = np.floor(value / self.lethal_cost_threshold * LETHAL_OBSTACLE).clip(0, 255)
        out[lethal] = LETHAL_OBSTACLE
        out[value == unknown] = NO_INFORMATION if self.track_unknown_space else FREE_SPACE
        return out

    def set_map(self, occupancy, resolution, origin):
        """A new map: occupancy (H, W) int8 OccupancyGrid values, row 0 lowest y;
        resolution [m]; origin (x [m], y [m], yaw [rad]) with yaw 0.

        A non-rolling master is resized to the map, as costmap_2d does.
        """
        occupancy = np.asarray(occupancy)
        if occupancy.ndim != 2 or occupancy.size == 0:
            raise CostmapError(f"static layer '{self.name}': map must be a non-empty 2D array")
        if abs(float(origin[2])) > 1e-9:
            raise CostmapError(f"static layer '{self.name}': a rotated map origin "
                               f"(yaw {origin[2]}) is not supported, as in costmap_2d")
        h, w = occupancy.shape
        self.grid = Costmap2D(w, h, resolution, origin[0], origin[1], NO_INFORMATION)
        self.grid.data[...] = self.interpret(occupancy)
        if self.layered is not None and not self.layered.rolling_window:
            m = self.layered.master
            if (m.size_x, m.size_y, m.resolution, m.origin_x, m.origin_y) != \
                    (w, h, float(resolution), float(origin[0]), float(origin[1])):
                self.layered.resize_map(w, h, resolution, origin[0], origin[1])
        self._dirty = True

    def update_bounds(self, robot_x, robot_y, robot_yaw, bounds):
        if self.grid is None:
            return bounds
        if self.layered.rolling_window or self._dirty:
            self._dirty = False
            g = self.grid
            w, h = g.size_in_meters
            return expand_bounds(bounds, g.origin_x, g.origin_y, g.origin_x + w, g.origin_y + h)
        return bounds

    def update_costs(self, master, window):
        if self.grid is None:
            return
        x0, y0, x1, y1 = window
        if not self.layered.rolling_window:
            src = self.grid.data[y0:y1, x0:x1]
            dst = master.data[y0:y1, x0:x1]
            if self.use_maximum:
                _update_with_max(dst, src)
            else:
                dst[...] = src  # updateWithTrueOverwrite
            return
        # Rolling window: sample the static grid at the master's cell centres.
        res = master.resolution
        xs = master.origin_x + (np.arange(x0, x1) + 0.5) * res
        ys = master.origin_y + (np.arange(y0, y1) + 0.5) * res
        g = self.grid
        gx = np.floor((xs - g.origin_x) / g.resolution).astype(np.int64)
        gy = np.floor((ys - g.origin_y) / g.resolution).astype(np.int64)
        okx = (gx >= 0) & (gx < g.size_x)
        oky = (gy >= 0) & (gy < g.size_y)
        if not okx.any() or not oky.any():
            return
        sub = g.data[np.ix_(gy[oky], gx[okx])]
        dst = master.data[y0:y1, x0:x1][np.ix_(np.flatnonzero(oky), np.flatnonzero(okx))]
        if self.use_maximum:
            _update_with_max(dst, sub)
        else:
            dst = sub
        master.data[np.ix_(y0 + np.flatnonzero(oky), x0 + np.flatnonzero(okx))] = dst

    def reset(self):
        self._dirty = True


def _update_with_max(dst, src):
    """costmap_2d's updateWithMax, in place: unknown source cells do not count."""
    known = src != NO_INFORMATION
    take = known & ((dst == NO_INFORMATION) | (dst < src))
    dst[take] = src[take]


def _update_with_overwrite(dst, src):
    """costmap_2d's updateWithOverwrite, in place: every known source cell wins."""
    known = src != NO_INFORMATION
    dst[known] = src[known]


# ---------------------------------------------------------------------------------------
@dataclass
class Observation:
    """One sensor reading in the costmap frame (costmap_2d's Observation).

    origin: sensor position (x, y) [m]; points: (N, 2) ray end points [m];
    mark: (N,) bool, False for rays that may only clear (no-return beams with
    inf_is_valid); obstacle_range / raytrace_range [m]; marking / clearing: what this
    source is allowed to do. z: height [m] of the (level, planar) sensor and so of all
    its points in the costmap frame, None when unknown (then no height test);
    min_obstacle_height / max_obstacle_height [m]: the source's height band (costmap_2d's
    observation buffer keeps only points within it); source: its name, for messages.
    heights: (N,) z [m] of each point in the costmap frame for a point cloud (then z is
    the sensor's own height and the band was applied when the cloud was read), None for
    a planar scan.
    """

    origin: tuple
    points: np.ndarray
    mark: np.ndarray
    obstacle_range: float = 2.5
    raytrace_range: float = 3.0
    marking: bool = True
    clearing: bool = True
    z: float = None
    min_obstacle_height: float = 0.0
    max_obstacle_height: float = 2.0
    source: str = ""
    heights: np.ndarray = None


def scan_to_observation(ranges, angle_min, angle_increment, range_min, range_max,
                        sensor_pose, inf_is_valid=False, obstacle_range=2.5,
                        raytrace_range=3.0, marking=True, clearing=True, sensor_z=None,
                        min_obstacle_height=0.0, max_obstacle_height=2.0, source=""):
    """A LaserScan's ranges [m] -> Observation in the costmap frame.

    sensor_pose: (x [m], y [m], yaw [rad]) of the laser in the costmap frame; sensor_z:
    its height [m] there (None: unknown); the source's height band and name are passed
    on to the Observation (the layer applies them). Readings
    below range_min or NaN are dropped (as laser_geometry does). A no-return (+inf, or a
    finite reading >= range_max, which some drivers report as range_max + 1) is dropped
    unless inf_is_valid, in which case it becomes a clearing-only ray of length
    range_max: it clears to raytrace_range but never marks, so max-range readings leave
    no ghost obstacles whatever obstacle_range is.
    """
    r = np.asarray(ranges, dtype=np.float64)
    ang = angle_min + angle_increment * np.arange(r.size) + sensor_pose[2]
    with np.errstate(invalid="ignore"):
        no_return = np.isposinf(r) | (np.isfinite(r) & (r >= range_max))
        hit = np.isfinite(r) & (r >= range_min) & (r < range_max)
    keep = hit | (no_return & inf_is_valid)
    length = np.where(hit, r, range_max)[keep]
    a = ang[keep]
    pts = np.column_stack([sensor_pose[0] + length * np.cos(a), sensor_pose[1] + length * np.sin(a)])
    return Observation(origin=(float(sensor_pose[0]), float(sensor_pose[1])), points=pts,
                       mark=hit[keep], obstacle_range=obstacle_range,
                       raytrace_range=raytrace_range, marking=marking, clearing=clearing,
                       z=None if sensor_z is None else float(sensor_z),
                       min_obstacle_height=min_obstacle_height,
                       max_obstacle_height=max_obstacle_height, source=source)


def source_observation(src, ranges, angle_min, angle_increment, range_min, range_max, sensor_pose,
                       sensor_z=None):
    """A LaserScan of observation source src (an ObstacleLayer.sources entry) -> its
    Observation, with the source's marking, clearing, ranges, inf_is_valid and height band
    (scan_to_observation's other arguments)."""
    return scan_to_observation(ranges, angle_min, angle_increment, range_min, range_max, sensor_pose,
                               src["inf_is_valid"], src["obstacle_range"], src["raytrace_range"],
                               src["marking"], src["clearing"], sensor_z=sensor_z,
                               min_obstacle_height=src["min_obstacle_height"],
                               max_obstacle_height=src["max_obstacle_height"], source=src["name"])


def cloud_to_observation(points, origin, obstacle_range=2.5, raytrace_range=3.0, marking=True,
                         clearing=True, min_obstacle_height=0.0, max_obstacle_height=2.0, source=""):
    """A point cloud in the costmap frame -> Observation (a PointCloud or PointCloud2 source).

    points: (N, 3) [m]; origin: (x, y, z) [m] of the sensor. As costmap_2d's observation
    buffer, only finite points within the source's [min_obstacle_height,
    max_obstacle_height] are kept, for marking and clearing alike; as its obstacle layer,
    a point marks only when nearer the sensor than obstacle_range in 3D, and every kept
    point clears along its ray projected on the ground (up to raytrace_range). The
    layer's own max_obstacle_height is applied per point when it takes the observation.
    """
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    keep = np.isfinite(p).all(axis=1) & (p[:, 2] >= min_obstacle_height) & (p[:, 2] <= max_obstacle_height)
    p = p[keep]
    o = np.asarray(origin, dtype=np.float64)
    mark = np.linalg.norm(p - o, axis=1) < obstacle_range
    return Observation(origin=(float(o[0]), float(o[1])), points=p[:, :2], mark=mark,
                       obstacle_range=obstacle_range, raytrace_range=raytrace_range, marking=marking,
                       clearing=clearing, z=float(o[2]), min_obstacle_height=min_obstacle_height,
                       max_obstacle_height=max_obstacle_height, source=source, heights=p[:, 2])


def source_cloud_observation(src, points, origin):
    """A point cloud of observation source src (an ObstacleLayer.sources entry) -> its
    Observation (cloud_to_observation with the source's ranges, flags and height band)."""
    return cloud_to_observation(points, origin, src["obstacle_range"], src["raytrace_range"], src["marking"],
                                src["clearing"], src["min_obstacle_height"], src["max_obstacle_height"],
                                src["name"])


def ray_cells(x0, y0, x1, y1):
    """Cells on straight lines from cell (x0, y0) to cells (x1, y1), all rays at once.

    x0, y0: int start cell; x1, y1: (N,) int end cells. Returns (ray index (M,),
    cx (M,), cy (M,)) for every cell of every ray, ends included: costmap_2d's
    raytraceLine (summit_nav_common.line_cells, halves away from zero).
    """
    return line_cells(x0, y0, x1, y1, ties="away")


SUPERSAMPLE = 2  # clearing samples per cell along a ray [1/cell]


def ray_cells_continuous(x0, y0, x1, y1):
    """Cells under straight rays from continuous grid point (x0, y0) to points (x1, y1).

    Coordinates in cells (cell (i, j) covers [i, i+1) x [j, j+1)). Samples every
    1/SUPERSAMPLE cell along the dominant axis; returns (ray index, cx, cy) (M,) each,
    with repeats. The obstacle layer clears with summit_nav_common.grid_kernels.fill_rays,
    which samples the same points; this is its oracle.
    """
    x1 = np.asarray(x1, dtype=np.float64)
    y1 = np.asarray(y1, dtype=np.float64)
    dx, dy = x1 - x0, y1 - y0
    n = np.ceil(SUPERSAMPLE * np.maximum(np.abs(dx), np.abs(dy))).astype(np.int64)
    n = np.maximum(n, 1)
    counts = n + 1
    ray = np.repeat(np.arange(n.size), counts)
    starts = np.cumsum(counts) - counts
    t = (np.arange(ray.size) - np.repeat(starts, counts)) / n[ray]
    return (ray, np.floor(x0 + t * dx[ray]).astype(np.int64),
            np.floor(y0 + t * dy[ray]).astype(np.int64))


raytrace_reference = line_cells_reference   # the oracle of ray_cells (ties away from zero)


def cells_inside_convex(polygon, grid, inset, whole_cells=False):
    """(rows, cols) of the grid cells whose centres lie at least inset [m] inside a convex
    polygon (N, 2) [m] (either winding); with whole_cells, whose whole squares do (each
    edge's inset grows by the square's half-extent along the edge normal, res/2 x
    (|nx| + |ny|)). Cells off the grid are left out."""
    poly = np.asarray(polygon, dtype=np.float64)
    res = grid.resolution
    lo = np.floor((poly.min(axis=0) - (grid.origin_x, grid.origin_y)) / res).astype(np.int64)
    hi = np.ceil((poly.max(axis=0) - (grid.origin_x, grid.origin_y)) / res).astype(np.int64)
    x0, y0 = max(0, int(lo[0])), max(0, int(lo[1]))
    x1, y1 = min(grid.size_x, int(hi[0]) + 1), min(grid.size_y, int(hi[1]) + 1)
    if x0 >= x1 or y0 >= y1 or len(poly) < 3:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    my, mx = np.mgrid[y0:y1, x0:x1]
    cx = grid.origin_x + (mx + 0.5) * res
    cy = grid.origin_y + (my + 0.5) * res
    a, b = poly, np.roll(poly, -1, axis=0)
    area2 = float(np.sum(a[:, 0] * b[:, 1] - b[:, 0] * a[:, 1]))  # > 0: counter-clockwise
    inside = np.ones(cx.shape, dtype=bool)
    for (ax, ay), (bx, by) in zip(a, b):
        ex, ey = bx - ax, by - ay
        n = math.hypot(ex, ey)
        if n == 0.0:
            continue
        # Signed distance to the edge's line, positive on the polygon's side.
        d = (ex * (cy - ay) - ey * (cx - ax)) / n * (1.0 if area2 > 0 else -1.0)
        square = 0.5 * res * (abs(ex) + abs(ey)) / n if whole_cells else 0.0
        inside &= d >= inset + square - 1e-9  # [m] a square flush with an edge counts
    return my[inside], mx[inside]


class ObstacleLayer(Layer):
    """Obstacles seen by the sensors (costmap_2d::ObstacleLayer), in its own grid.

    Parameters (costmap_2d names): observation_sources (names; each a dict with
    data_type (LaserScan, PointCloud2, or PointCloud: costmap_2d's default), topic, sensor_frame, marking, clearing, obstacle_range, raytrace_range,
    inf_is_valid, min_obstacle_height [m] (0), max_obstacle_height [m] (2), ... read by
    the node), obstacle_range [m] and raytrace_range [m] (defaults for sources),
    max_obstacle_height [m] (nothing higher marks), track_unknown_space (default: the
    costmap's), footprint_clearing_enabled, combination_method (0 overwrite, 1 maximum,
    other: do not write), enabled.

    Heights, as costmap_2d's observation buffer and obstacle layer: a scan whose sensor
    height lies outside its source's [min_obstacle_height, max_obstacle_height] neither
    marks nor clears; one above the layer's max_obstacle_height does not mark. Either is
    warned about once. A point cloud's points are kept or dropped by their own heights
    (cloud_to_observation), and one above the layer's max_obstacle_height does not mark.

    Each update: all clearing observations first clear the cells along their rays out
    to raytrace_range; then all marking observations mark their end points lying
    within obstacle_range (costmap_2d's order, so a fresh hit survives the clearing).
    """

    SCHEMA = Schema([
        Field("enabled", BOOL, True), Field("observation_sources", SPACED_NAMES, ""),
        Field("obstacle_range", FLOAT, 2.5, lo=0.0), Field("raytrace_range", FLOAT, 3.0, lo=0.0),   # [m]
        Field("max_obstacle_height", FLOAT, 2.0),                                                    # [m]
        # None: the costmap's track_unknown_space, known at initialize (as costmap_2d)
        Field("track_unknown_space", BOOL, None, optional=True),
        Field("footprint_clearing_enabled", BOOL, True), Field("combination_method", FLOAT, 1)],
        accepted=("min_obstacle_height", "inf_is_valid"))   # costmap_2d's, read by no layer here
    PARAMS = tuple(SCHEMA.known)
    SOURCE_ACCEPTED = ("clear_on_max_reading",)

    @staticmethod
    def source_schema(name, obstacle_range, raytrace_range):
        """An observation source's parameters; its ranges default to the layer's [m]."""
        return Schema([
            Field("topic", STR, name), Field("sensor_frame", STR, ""),
            Field("data_type", STR, "PointCloud", choices=("LaserScan", "PointCloud", "PointCloud2")),
            Field("marking", BOOL, True), Field("clearing", BOOL, False),
            Field("obstacle_range", FLOAT, obstacle_range, lo=0.0), Field("raytrace_range", FLOAT, raytrace_range, lo=0.0),
            Field("inf_is_valid", BOOL, False),
            Field("expected_update_rate", FLOAT, 0.0, lo=0.0), Field("observation_persistence", FLOAT, 0.0, lo=0.0),
            Field("min_obstacle_height", FLOAT, 0.0), Field("max_obstacle_height", FLOAT, 2.0)],
            accepted=ObstacleLayer.SOURCE_ACCEPTED)

    def __init__(self, name, params=None):
        super().__init__(name)
        params = dict(params or {})
        sources = params.get("observation_sources", "")
        r = _read(self.SCHEMA, {k: v for k, v in params.items()
                                if not (isinstance(sources, str) and k in sources.split())}, name, "obstacle")
        self.notes += r.notes
        vars(self).update({k: v for k, v in r.values.items() if k != "observation_sources"})
        self.source_names = r["observation_sources"].split()
        self.combination_method = int(self.combination_method)
        self.sources = {}
        for s in self.source_names:
            sp = params.get(s, {})
            if not isinstance(sp, dict):
                raise CostmapError(f"obstacle layer '{name}': source '{s}' must be a dict of parameters")
            src = self.source_schema(s, self.obstacle_range, self.raytrace_range).read(
                sp, f"{name}/{s}", f"obstacle layer '{name}' source '{s}'", error=CostmapError)
            self.notes += src.notes
            self.sources[s] = dict(src.values, name=s)
        self.grid = None
        self._pending = []
        self._footprint_xy = None

    def initialize(self, layered):
        super().initialize(layered)
        if self.track_unknown_space is None:
            self.track_unknown_space = layered.track_unknown_space
        self.match_size()

    def _default(self):
        return NO_INFORMATION if self.track_unknown_space else FREE_SPACE

    def match_size(self):
        m = self.layered.master
        g = self.grid
        if g is None or (g.size_x, g.size_y, g.resolution) != (m.size_x, m.size_y, m.resolution):
            self.grid = Costmap2D(m.size_x, m.size_y, m.resolution, m.origin_x, m.origin_y,
                                  self._default())
        elif (g.origin_x, g.origin_y) != (m.origin_x, m.origin_y):
            g.update_origin(m.origin_x, m.origin_y)
            # Rounding to whole cells: snap exactly to the master's origin.
            g.origin_x, g.origin_y = m.origin_x, m.origin_y

    def add_observation(self, obs):
        """Queue an Observation for the next update_bounds, after the height tests."""
        what = f"obstacle layer '{self.name}' source '{obs.source}'"
        if obs.heights is not None:   # a point cloud: each point marks by its own height
            obs = dataclasses.replace(obs, mark=np.asarray(obs.mark, dtype=bool) & self.marks_at(obs.heights),
                                      clearing=obs.clearing and self.clears_from(obs.z, what))
        elif obs.z is not None:
            if not obs.min_obstacle_height <= obs.z <= obs.max_obstacle_height:
                self._warn(f"{what}: the sensor is at z = {obs.z:.3f} m, outside the source's "
                           f"[min_obstacle_height, max_obstacle_height] = [{obs.min_obstacle_height}, "
                           f"{obs.max_obstacle_height}] m: its scans mark and clear nothing, as in costmap_2d")
                return
            marks, clears = self.height_allows(obs.z, what)
            if not (marks and obs.marking) and not (clears and obs.clearing):
                return
            obs = dataclasses.replace(obs, marking=obs.marking and marks, clearing=obs.clearing and clears)
        self._pending.append(obs)

    def marks_at(self, heights):
        """(N,) bool: which points of a cloud at these heights [m] may mark (costmap_2d's
        obstacle layer skips a point above its max_obstacle_height)."""
        return np.asarray(heights) <= self.max_obstacle_height

    def clears_from(self, z, what):
        """Whether a cloud's sensor at height z [m] may clear (always, in 2D)."""
        return True

    def height_allows(self, z, what):
        """(may mark, may clear) for a planar sensor at height z [m]; warns once when not."""
        if z > self.max_obstacle_height:
            self._warn(f"{what}: the sensor is at z = {z:.3f} m, above the layer's max_obstacle_height "
                       f"{self.max_obstacle_height} m: its scans mark nothing, as in costmap_2d")
            return False, True
        return True, True

    def _warn(self, message):
        if self.layered is not None:
            self.layered.warn_once(message)

    def update_bounds(self, robot_x, robot_y, robot_yaw, bounds):
        obs, self._pending = self._pending, []
        for o in obs:
            if o.clearing:
                bounds = self._raytrace_clear(o, bounds)
        for o in obs:
            if o.marking:
                bounds = self._mark(o, bounds)
        if self.footprint_clearing_enabled:
            fp = self.layered.footprint.oriented(robot_x, robot_y, robot_yaw)
            self._footprint_xy = fp
            bounds = expand_bounds(bounds, fp[:, 0].min(), fp[:, 1].min(),
                                   fp[:, 0].max(), fp[:, 1].max())
        return bounds

    def _raytrace_clear(self, o, bounds):
        g = self.grid
        pts = np.asarray(o.points, dtype=np.float64).reshape(-1, 2)
        if pts.size == 0:
            return bounds
        ox, oy = o.origin
        cell0 = g.world_to_map(ox, oy)
        if cell0 is None:
            return bounds  # costmap_2d: sensor origin off the map -> no clearing
        d = pts - np.array([ox, oy])
        dist = np.hypot(d[:, 0], d[:, 1])
        scale = np.where(dist > o.raytrace_range, o.raytrace_range / np.maximum(dist, 1e-12), 1.0)
        ends = np.array([ox, oy]) + d * scale[:, None]
        # Walk the exact (continuous) rays at SUPERSAMPLE points per cell, so the cell
        # of a hit that lies on a ray is crossed by the clearing of that ray.
        gx0 = (ox - g.origin_x) / g.resolution
        gy0 = (oy - g.origin_y) / g.resolution
        # (compiled: ray_cells_continuous, its oracle, lays out every ray's cells at once,
        # several MB per scan, which was move_base's peak memory)
        fill_rays(g.data, gx0, gy0, (ends[:, 0] - g.origin_x) / g.resolution,
                  (ends[:, 1] - g.origin_y) / g.resolution, SUPERSAMPLE, FREE_SPACE)
        r = o.raytrace_range
        return expand_bounds(bounds, ox - r, oy - r, ox + r, oy + r)

    def _mark(self, o, bounds):
        g = self.grid
        pts = np.asarray(o.points, dtype=np.float64).reshape(-1, 2)
        if pts.size == 0:
            return bounds
        d = pts - np.array(o.origin)
        near = (np.hypot(d[:, 0], d[:, 1]) <= o.obstacle_range) & np.asarray(o.mark, dtype=bool)
        mx, my, inside = g.world_to_map_array(pts[near])
        g.data[my[inside], mx[inside]] = LETHAL_OBSTACLE
        if inside.any():
            p = pts[near][inside]
            bounds = expand_bounds(bounds, p[:, 0].min(), p[:, 1].min(), p[:, 0].max(), p[:, 1].max())
        return bounds

    def update_costs(self, master, window):
        if self._footprint_xy is not None:
            # Ours, stricter than costmap_2d (which rasterizes the padded footprint with
            # its outline): only cells wholly under the robot's unpadded body are cleared.
            # A wall cell the outline merely grazes is a wall the robot brushes past; with
            # it cleared, DWA saw a few centimetres of room that were not there and drove
            # into the wall (willow-full exploration). A real obstacle cannot lie wholly
            # under the body, so nothing real is lost.
            my, mx = cells_inside_convex(self._footprint_xy, self.grid, self.layered.footprint.padding,
                                         whole_cells=True)
            self.grid.data[my, mx] = FREE_SPACE
        x0, y0, x1, y1 = window
        src = self.grid.data[y0:y1, x0:x1]
        dst = master.data[y0:y1, x0:x1]
        if self.combination_method == 0:
            _update_with_overwrite(dst, src)
        elif self.combination_method == 1:
            _update_with_max(dst, src)

    def reset(self):
        self.grid.reset()
        self._pending = []

    def clear_window(self, window, invert=False):
        """Reset this layer's cells inside (or, with invert, outside) a cell window."""
        self.grid.clear_area(window, invert)

    def set_window_cost(self, window, cost):
        """Set this layer's cells in the cell window (x0, y0, x1, y1), x1 and y1 excluded, to
        cost (costmap_2d's setConvexPolygonCost for an axis-aligned square)."""
        x0, y0, x1, y1 = (int(v) for v in window)
        g = self.grid
        x0, x1, y0, y1 = max(0, x0), min(g.size_x, x1), max(0, y0), min(g.size_y, y1)
        if x1 > x0 and y1 > y0:
            g.data[y0:y1, x0:x1] = cost


# ---------------------------------------------------------------------------------------
def inflation_cost(distance, inscribed_radius, cost_scaling_factor):
    """costmap_2d's inflation cost for a cell at ``distance`` [m] from the nearest lethal cell.

    0 -> LETHAL_OBSTACLE; <= inscribed_radius -> INSCRIBED_INFLATED_OBSTACLE; beyond:
    (INSCRIBED - 1) * exp(-cost_scaling_factor * (distance - inscribed_radius)),
    truncated to an integer as costmap_2d's unsigned char cast does. Works on arrays.
    """
    d = np.asarray(distance, dtype=np.float64)
    factor = np.exp(-cost_scaling_factor * (d - inscribed_radius))
    cost = np.floor((INSCRIBED_INFLATED_OBSTACLE - 1) * np.minimum(factor, 1.0)).astype(np.uint8)
    cost = np.where(d <= inscribed_radius, INSCRIBED_INFLATED_OBSTACLE, cost)
    return np.where(d == 0, LETHAL_OBSTACLE, cost).astype(np.uint8)


class InflationLayer(Layer):
    """Inflate lethal cells with costs that decay with distance (costmap_2d::InflationLayer).

    Parameters: inflation_radius [m] (costs stop beyond it), cost_scaling_factor [1/m]
    (decay rate), inflate_unknown (unknown cells also inflate), enabled. The inscribed
    radius comes from the costmap's footprint. Distances are exact Euclidean distances
    between cell centres (grid_kernels.distance_transform: OpenCV's DIST_MASK_PRECISE), as costmap_2d's
    cell-offset distance table; cells farther than ceil(inflation_radius / resolution)
    cells get nothing.
    """

    SCHEMA = Schema([Field("enabled", BOOL, True), Field("inflation_radius", FLOAT, 0.55, lo=0.0),   # [m]
                     Field("cost_scaling_factor", FLOAT, 10.0, lo=0.0), Field("inflate_unknown", BOOL, False)])
    PARAMS = tuple(SCHEMA.fields)

    def __init__(self, name, params=None):
        super().__init__(name)
        r = _read(self.SCHEMA, params, name, "inflation")
        self.notes += r.notes
        vars(self).update(r.values)   # enabled, inflation_radius [m], cost_scaling_factor, inflate_unknown

    def cell_inflation_radius(self, resolution):
        """[cells] costmap_2d's cellDistance(inflation_radius)."""
        return int(max(0.0, math.ceil(self.inflation_radius / resolution - 1e-9)))

    def update_bounds(self, robot_x, robot_y, robot_yaw, bounds):
        if bounds[0] > bounds[2]:
            return bounds
        r = self.inflation_radius
        return (bounds[0] - r, bounds[1] - r, bounds[2] + r, bounds[3] + r)

    def update_costs(self, master, window):
        x0, y0, x1, y1 = window
        res = master.resolution
        rc = self.cell_inflation_radius(res)
        # Sources may lie up to rc cells outside the window.
        ex0, ey0 = max(0, x0 - rc), max(0, y0 - rc)
        ex1, ey1 = min(master.size_x, x1 + rc), min(master.size_y, y1 + rc)
        region = master.data[ey0:ey1, ex0:ex1]
        src = region == LETHAL_OBSTACLE
        if self.inflate_unknown:
            src |= region == NO_INFORMATION
        if not src.any():
            return
        dist = distance_transform((~src).astype(np.uint8))
        dist = dist[y0 - ey0:y1 - ey0, x0 - ex0:x1 - ex0]
        cost = inflation_cost(dist * res, self.layered.inscribed_radius, self.cost_scaling_factor)
        cost[dist > rc + 1e-3] = FREE_SPACE
        old = master.data[y0:y1, x0:x1]
        unknown = old == NO_INFORMATION
        new = np.maximum(old, cost)
        if self.inflate_unknown:
            keep_unknown = unknown & (cost == FREE_SPACE)
        else:
            keep_unknown = unknown & (cost < INSCRIBED_INFLATED_OBSTACLE)
        new[unknown] = cost[unknown]
        new[keep_unknown] = NO_INFORMATION
        master.data[y0:y1, x0:x1] = new


class VoxelLayer(ObstacleLayer):
    """costmap_2d::VoxelLayer in 2D: an obstacle layer with a vertical extent.

    Reference: costmap_2d ``voxel_layer.cpp`` and wiki.ros.org/costmap_2d/hydro/obstacles.
    A level 2D laser's points all lie at the sensor's height, so a column of voxels holds
    at most one marked voxel per sensor and the 2D grid is the whole state. Kept from
    the voxel grid: its height band [origin_z, origin_z + z_voxels * z_resolution) [m].
    A point above it, or above max_obstacle_height, does not mark (one below origin_z
    marks the lowest voxel, as in costmap_2d); a sensor outside it cannot raytrace, so
    clears nothing. unknown_threshold, mark_threshold and publish_voxel_map have no
    meaning in 2D (this layer marks a cell from one voxel, as mark_threshold 0, and
    publishes no voxel grid): accepted and logged once as ignored. A point cloud's points
    mark by the same height rules, but its rays clear whole columns, as the 2D obstacle
    layer does (the real voxel layer clears only the voxels a 3D ray crosses, so a ray
    passing above a low obstacle leaves it marked there, not here).
    """

    VOXEL_SCHEMA = Schema([
        Field("origin_z", FLOAT, 0.0), Field("z_resolution", FLOAT, 0.2, lo=0, lo_open=True),   # [m]
        Field("z_voxels", Z_VOXELS, 10),
        Field("unknown_threshold", FLOAT, 0, lo=0), Field("mark_threshold", FLOAT, 0, lo=0),
        Field("publish_voxel_map", BOOL, False)])
    VOXEL_PARAMS = tuple(VOXEL_SCHEMA.fields)
    IGNORED_2D = ("unknown_threshold", "mark_threshold", "publish_voxel_map")
    PARAMS = ObstacleLayer.PARAMS + VOXEL_PARAMS

    def __init__(self, name, params=None):
        params = dict(params or {})
        r = self.VOXEL_SCHEMA.read({k: v for k, v in params.items() if k in self.VOXEL_PARAMS}, name,
                                   error=CostmapError)
        self.origin_z, self.z_resolution, self.z_voxels = r["origin_z"], r["z_resolution"], r["z_voxels"]
        super().__init__(name, {k: v for k, v in params.items() if k not in self.VOXEL_PARAMS})
        self.notes += [Note(WARNING, k, f"voxel layer '{name}': '{k}' has no meaning for a 2D costmap; ignored")
                       for k in self.IGNORED_2D if k in params]

    @property
    def top_z(self):
        """[m] the top of the voxel grid."""
        return self.origin_z + self.z_voxels * self.z_resolution

    def marks_at(self, heights):
        """A point above the voxel grid marks nothing (one below it marks the lowest voxel)."""
        return super().marks_at(heights) & (np.asarray(heights) < self.top_z)

    def _sensor_in_grid(self, z, what, loses):
        """Whether a sensor at height z [m] is inside the voxel grid (voxel_layer.cpp raytraces
        only from inside it); warns once, saying what its readings lose, when not."""
        if self.origin_z <= z < self.top_z:
            return True
        self._warn(f"{what}: the sensor is at z = {z:.3f} m, outside the voxel grid's [origin_z, origin_z + "
                   f"z_voxels * z_resolution) = [{self.origin_z}, {self.top_z:g}) m: {loses}, as in costmap_2d")
        return False

    def clears_from(self, z, what):
        return self._sensor_in_grid(z, what, "its clouds clear nothing")

    def height_allows(self, z, what):
        marks, clears = super().height_allows(z, what)
        loses = "its scans clear nothing" if z < self.origin_z else "its scans mark and clear nothing"
        if not self._sensor_in_grid(z, what, loses):
            clears = False
            marks = marks and z < self.origin_z
        return marks, clears


LAYER_TYPES = {}
for _t in STATIC_TYPES:
    LAYER_TYPES[_t] = StaticLayer
for _t in OBSTACLE_TYPES:
    LAYER_TYPES[_t] = ObstacleLayer
for _t in VOXEL_TYPES:
    LAYER_TYPES[_t] = VoxelLayer
for _t in INFLATION_TYPES:
    LAYER_TYPES[_t] = InflationLayer


def make_layer(type_name, name, params):
    """The layer for a costmap_2d plugin type string; CostmapError for an unknown type."""
    if type_name not in LAYER_TYPES:
        raise CostmapError(f"plugin '{name}': unknown type {type_name!r}; "
                           f"known: {sorted(LAYER_TYPES)}")
    return LAYER_TYPES[type_name](name, params)
