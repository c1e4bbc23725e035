"""Occupancy grid of a pose graph: every node's scan ray-traced from its optimized pose.

Reference: open_karto's OccupancyGrid (CreateFromScans / RayTrace / UpdateCell): each
beam frees the cells it passes and hits its end cell; a cell is occupied when hits /
passes exceeds `occupancy_threshold` (0.1) and unknown while fewer than
`min_pass_through` (2) beams crossed it; a reading beyond the range threshold frees cells
up to it and marks nothing. The ray casting is the project's (grid.PatchGrid.integrate_scan,
Bresenham lines as gmapping's registerScan) into a fresh grid.
"""
from typing import Tuple

import numpy as np

from ..grid import HITS, UNKNOWN, VISITS, PatchGrid, PatchPool, occupancy_values
from .pose_graph import compose

OCCUPANCY_THRESHOLD = 0.1   # open_karto's OccupancyThreshold: hits / passes above this [-]
MIN_PASS_THROUGH = 2        # open_karto's MinPassThrough: fewer passes leave a cell unknown [-]


def render(poses: np.ndarray, ranges: np.ndarray, beam_angles: np.ndarray, mount, range_threshold: float,
           range_max: float, resolution: float) -> Tuple[np.ndarray, Tuple[float, float]]:
    """(grid int8 (H, W) of -1 / 0 / 100, origin (x, y) [m] of cell (0, 0)'s corner).

    poses (N, 3): base poses in the map [m, m, rad]; ranges (N, n) [m] (NaN / inf / beyond
    range_max: no return, skipped); beam_angles (n,) in the laser frame [rad]; mount
    (x, y, yaw) of the laser in the base frame. Row 0 is the lowest y (OccupancyGrid order).
    """
    grid = PatchGrid(resolution, PatchPool(64))
    for pose, r in zip(np.asarray(poses, float), np.asarray(ranges, float)):
        laser = compose(pose, mount)
        grid.integrate_scan(laser, r, beam_angles, range_threshold, range_max)
    b = grid.bounds()
    if b is None:
        return np.full((1, 1), UNKNOWN, np.int8), (0.0, 0.0)
    ix0, iy0, ix1, iy1 = b
    layers = grid.read_layers(ix0, iy0, ix1 - ix0, iy1 - iy0)
    hits, visits = layers[HITS], layers[VISITS]
    out = occupancy_values(hits, visits, OCCUPANCY_THRESHOLD)
    out[visits < MIN_PASS_THROUGH] = UNKNOWN
    return out, (ix0 * resolution, iy0 * resolution)
