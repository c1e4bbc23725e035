"""Occupancy grid of a pose graph: every node's scan ray-traced from its optimized pose.

Reference: open_karto's OccupancyGrid (CreateFromScans / RayTrace / UpdateCell): each
beam frees the cells it passes and hits its end cell; a cell is occupied when hits /
passes exceeds `occupancy_threshold` (0.1) and unknown while fewer than
`min_pass_through` (2) beams crossed it; a reading beyond the range threshold frees cells
up to it and marks nothing. The ray casting is the project's (grid.PatchGrid.integrate_scan,
Bresenham lines as gmapping's registerScan).

open_karto casts every scan anew for each map; `Renderer` keeps its counts while the
poses it cast from stay as they were and casts only the nodes added since, so a map
between loop closures costs the new scans, not the whole graph. Integration runs in node
order either way, so the counts (and the map) are those of a fresh cast.
"""
from typing import Optional, Tuple

import numpy as np

from ..grid import HITS, UNKNOWN, VISITS, PatchGrid, PatchPool, occupancy_values
from .pose_graph import compose

OCCUPANCY_THRESHOLD = 0.1   # open_karto's OccupancyThreshold: hits / passes above this [-]
MIN_PASS_THROUGH = 2        # open_karto's MinPassThrough: fewer passes leave a cell unknown [-]
CHUNK = 128                 # nodes whose scans Renderer asks for at a time


def render(poses: np.ndarray, ranges: np.ndarray, beam_angles: np.ndarray, mount, range_threshold: float,
           range_max: float, resolution: float) -> Tuple[np.ndarray, Tuple[float, float]]:
    """(grid int8 (H, W) of -1 / 0 / 100, origin (x, y) [m] of cell (0, 0)'s corner).

    poses (N, 3): base poses in the map [m, m, rad]; ranges (N, n) [m] (NaN / inf / beyond
    range_max: no return, skipped); beam_angles (n,) in the laser frame [rad]; mount
    (x, y, yaw) of the laser in the base frame. Row 0 is the lowest y (OccupancyGrid order).
    """
    return Renderer().render(poses, ranges, beam_angles, mount, range_threshold, range_max, resolution)


class Renderer:
    """render() that casts again only what changed since its last call (module docstring)."""

    def __init__(self):
        self._grid: Optional[PatchGrid] = None
        self._poses = np.zeros((0, 3))     # the poses cast into _grid, in node order
        self._setup = None                 # what else the counts depend on

    def render(self, poses, ranges, beam_angles, mount, range_threshold, range_max, resolution):
        """As render(); ranges may be a callable (k0, k1) -> ranges (k1 - k0, n) of nodes
        k0..k1-1, or -> (ranges, no_hit (k1 - k0, n) bool): beams that free their line of
        sight and mark nothing (grid.PatchGrid.integrate_scan). The callable is asked for
        CHUNK nodes at a time: the caller keeps its scans compact (float32) and need not
        build the rows already cast, nor all of them at once after a loop closure (4000
        nodes of 1081 beams in float64 are 35 MB)."""
        poses = np.asarray(poses, float)
        setup = (float(resolution), float(range_threshold), float(range_max), tuple(np.asarray(mount, float)),
                 np.asarray(beam_angles, float).tobytes())
        done = len(self._poses)
        if (self._grid is None or setup != self._setup or done > len(poses)
                or not np.array_equal(poses[:done], self._poses)):
            self._grid, self._setup, done = PatchGrid(resolution, PatchPool(64)), setup, 0
        if not callable(ranges):
            table = np.asarray(ranges, float)
            ranges = lambda k0, k1: table[k0:k1]   # noqa: E731
        for k0 in range(done, len(poses), CHUNK):
            k1 = min(k0 + CHUNK, len(poses))
            new = ranges(k0, k1)
            new, no_hit = new if isinstance(new, tuple) else (new, None)
            new = np.asarray(new, float)
            for k, (pose, r) in enumerate(zip(poses[k0:k1], new)):
                self._grid.integrate_scan(compose(pose, mount), r, beam_angles, range_threshold, range_max,
                                          None if no_hit is None else no_hit[k])
        self._poses = poses.copy()
        return _occupancy(self._grid, resolution)


def _occupancy(grid: PatchGrid, resolution: float):
    b = grid.bounds()
    if b is None:
        return np.full((1, 1), UNKNOWN, np.int8), (0.0, 0.0)
    ix0, iy0, ix1, iy1 = b
    layers = grid.read_layers(ix0, iy0, ix1 - ix0, iy1 - iy0, layers=VISITS + 1)   # the counts only
    hits, visits = layers[HITS], layers[VISITS]
    out = occupancy_values(hits, visits, OCCUPANCY_THRESHOLD)
    out[visits < MIN_PASS_THROUGH] = UNKNOWN
    return out, (ix0 * resolution, iy0 * resolution)
