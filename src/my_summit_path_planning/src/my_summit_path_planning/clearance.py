"""Footprint clearance from blocked cells, and how low a motion may let it go.

``obstacle_distance``: the exact Euclidean distance [m] of each cell of a costmap to the
nearest lethal or unknown cell; ``footprint_clearance``: the clearance [m] of footprint
poses (circles covering the footprint, bilinear lookups, corners refined), negative
inside the padded footprint; ``ClearancePolicy``: the limits DWA, rotate_recovery,
back_up and turn_around check that clearance against (docs/move_base.md, "Clearance").
"""
import math
from dataclasses import dataclass

import numpy as np

from .cost_values import LETHAL_OBSTACLE, NO_INFORMATION
from summit_nav_common.geometry import wrap_angle
from summit_nav_common.grid_kernels import distance_transform, remap_bilinear

ESCAPE_SLACK = 1e-3        # [m] clearance a move may lose where it may lose none (see ClearancePolicy)
# [m] clearance loss tolerated in escape mode: the clearance measured along a motion
# parallel to a wall of laser-marked cells (ragged by a cell here and there, laser noise
# 1 cm) wobbles by a few millimetres. A fifth of a cell: the marked cells reach 0-5 cm
# past the surface that was hit, and the clearance keeps half a cell of margin besides.
ESCAPE_TOL = 0.01
ESCAPE_GAIN = 0.01         # [m] clearance a backing-up trajectory must regain in escape mode
OUTSIDE_DIST = -1.0e6      # [m] distance field value off the costmap (counts as a collision)
# The axis circles stick out ~0.25 m past a rectangle's ends: poses whose axis-circle
# clearance is below this are checked again with the footprint's finer grid circles.
FINE_CHECK_BELOW = 0.3     # [m]
FINE_MARGIN_CELLS = 1.0    # [cells] margin of the grid circles (the axis circles have half a cell)
# [cells] how much farther than half a cell a blocked cell's square reaches (its corner,
# diagonally): below this clearance the axis circles may miss a footprint corner in a cell.
CORNER_SLACK_CELLS = math.sqrt(0.5) - 0.5

def obstacle_distance(costmap):
    """Distance [m] from each cell to the nearest lethal or unknown cell centre (OpenCV's
    exact Euclidean distance transform); None when the costmap has no such cell."""
    data = costmap.data
    blocked = (data == LETHAL_OBSTACLE) | (data == NO_INFORMATION)
    if not blocked.any():
        return None
    return distance_transform((~blocked).astype(np.uint8)) * costmap.resolution


def footprint_checks(footprint):
    """(covers, corners) for footprint_clearance: the footprint's axis circles and grid
    circles, and its polygon's corners (None for a round robot, which has none)."""
    covers = (footprint.covering_circles(), footprint.grid_circles())
    return covers, (None if footprint.is_circle else footprint.polygon)


def footprint_clearance(dist_m, costmap, x, y, th, covers, corners=None):
    """Clearance [m] (negative: collision) of footprint poses from blocked cells.

    dist_m: (H, W) distance [m] of each cell centre to the nearest blocked (lethal or
    unknown) cell centre; x, y, th: poses (any shape, same) in the costmap frame;
    covers: ((centres (K, 2) [m], radius [m]), ...) circle sets that each cover the
    footprint. A cover proves a pose free when every circle's centre is farther than
    radius + a margin (half a cell for the first cover, FINE_MARGIN_CELLS for the
    others) from any blocked cell, so the clearance of a pose is the best
    of its covers' (min over circles of distance - radius - half a cell). The first
    cover is evaluated everywhere; each next one only where the clearance so far is
    below FINE_CHECK_BELOW (near obstacles: few poses). The distance field is
    interpolated bilinearly: a nearest-cell lookup would be off by up to half a cell
    diagonal and jump as the robot crosses cells.
    corners (K, 2) [m] (optional, robot frame): the footprint's corners, where the first
    cover's circles touch the outline and half a cell of margin falls short of a blocked
    cell's square by up to CORNER_SLACK_CELLS: a pose whose clearance is below that and
    that has a corner inside a blocked cell gets minus the corner's depth in it.
    """
    shape = np.shape(x)
    x = np.asarray(x, dtype=np.float64).ravel()
    y = np.asarray(y, dtype=np.float64).ravel()
    th = np.asarray(th, dtype=np.float64).ravel()
    field = np.asarray(dist_m, dtype=np.float32)
    (centres, radius), rest = covers[0], covers[1:]
    clear = _cover_clearance(field, costmap, x, y, th, centres, radius, 0.5 * costmap.resolution)
    for centres, radius in rest:
        near = np.flatnonzero(clear < FINE_CHECK_BELOW)
        if near.size == 0:
            break
        # The small circles pass through their cells' corners, right on the footprint's
        # outline: a whole cell of margin (a blocked cell's square reaches half a diagonal
        # past its centre, and the bilinear distance runs high next to a point obstacle).
        fine = _cover_clearance(field, costmap, x[near], y[near], th[near], centres, radius,
                                FINE_MARGIN_CELLS * costmap.resolution)
        clear[near] = np.maximum(clear[near], fine)
    if corners is not None:
        near = np.flatnonzero(clear < CORNER_SLACK_CELLS * costmap.resolution)
        if near.size:
            clear[near] = np.minimum(clear[near], _corner_clearance(
                field, costmap, x[near], y[near], th[near], np.asarray(corners, dtype=np.float64)))
    return clear.reshape(shape)


def _cover_clearance(field, costmap, x, y, th, centres, radius, margin):
    """min over the circles of (interpolated distance at the circle centre - radius - margin [m])."""
    res = costmap.resolution
    clear = np.full(x.shape, np.inf, dtype=np.float32)
    c, s = np.cos(th), np.sin(th)
    for cx, cy in centres:
        # Continuous cell-centre coordinates; remap_bilinear interpolates bilinearly (in
        # C, OpenCV's remap to the bit) and answers OUTSIDE_DIST off the grid.
        fx = ((x + cx * c - cy * s - costmap.origin_x) / res - 0.5).astype(np.float32)
        fy = ((y + cx * s + cy * c - costmap.origin_y) / res - 0.5).astype(np.float32)
        np.minimum(clear, remap_bilinear(field, fx, fy, OUTSIDE_DIST), out=clear)
    return clear.astype(np.float64) - (radius + margin)


def _corner_clearance(field, costmap, x, y, th, corners):
    """(N,) minus how deep [m] the deepest footprint corner lies inside a blocked cell
    (field <= 0), inf where no corner is in one; poses x, y, th (N,), corners (K, 2) [m]
    in the robot frame."""
    res = costmap.resolution
    h, w = field.shape
    c, s = np.cos(th)[:, None], np.sin(th)[:, None]
    fx = (x[:, None] + corners[:, 0] * c - corners[:, 1] * s - costmap.origin_x) / res  # (N, K) [cells]
    fy = (y[:, None] + corners[:, 0] * s + corners[:, 1] * c - costmap.origin_y) / res
    mx, my = np.floor(fx).astype(np.int64), np.floor(fy).astype(np.int64)
    inside = (mx >= 0) & (my >= 0) & (mx < w) & (my < h)
    blocked = inside & (field[my.clip(0, h - 1), mx.clip(0, w - 1)] <= 0.0)
    depth = res * (0.5 - np.maximum(np.abs(fx - mx - 0.5), np.abs(fy - my - 0.5)))  # to the cell's nearest side
    return np.where(blocked, -depth, np.inf).min(axis=1)


def _nearest_blocked(dist_m, costmap, pose):
    """'; nearest obstacle cell 0.52 m away, 170 deg from the heading' (for a failure reason)."""
    res = costmap.resolution
    h, w = costmap.data.shape
    r = int(math.ceil(1.0 / res))
    cell = costmap.world_to_map(pose[0], pose[1])
    if cell is None:
        return ""
    x0, y0 = max(0, cell[0] - r), max(0, cell[1] - r)
    sub = costmap.data[y0:min(h, cell[1] + r + 1), x0:min(w, cell[0] + r + 1)]
    ys, xs = np.nonzero((sub == LETHAL_OBSTACLE) | (sub == NO_INFORMATION))
    if len(xs) == 0:
        return "; no obstacle cell within 1 m"
    wx = costmap.origin_x + (xs + x0 + 0.5) * res - pose[0]
    wy = costmap.origin_y + (ys + y0 + 0.5) * res - pose[1]
    k = int(np.argmin(np.hypot(wx, wy)))
    bearing = math.degrees(wrap_angle(math.atan2(wy[k], wx[k]) - pose[2]))
    return f"; nearest obstacle cell {math.hypot(wx[k], wy[k]):.2f} m away, {bearing:.0f} deg from the heading"


# -- clearance policy ----------------------------------------------------------------
@dataclass(frozen=True)
class ClearancePolicy:
    """How low a motion's footprint clearance [m] (footprint_clearance: negative once the
    padded footprint overlaps a blocked cell) may go, from the robot's clearance c0 [m]
    now and the footprint_padding [m]: every limit DWA and the recoveries check against.

    - ``normal``: 0, the padded footprint never reaches a blocked cell (DWA with c0 >= 0
      off the inscribed zone; plain dwa_local_planner).
    - ``escape(floor)``: escape mode (c0 < 0, or no ordinary trajectory): ESCAPE_TOL
      below the clearance floor, for the millimetres the measured clearance along a wall
      of laser-marked cells wobbles by, but with a padding never past the unpadded
      footprint's edge (-padding), and once past it only ESCAPE_SLACK below the floor.
      With no padding there is no margin to keep.
    - ``escape_floor(c0, previous)``: the floor escape mode keeps, min(c0, 0), that only
      rises while the robot escapes; when the clearance falls below what it allows it
      starts over from c0 with no slack left (ESCAPE_SLACK below c0).
    - ``creep(floor, c0)``: a slow forward or turning move judged only up to where it
      could stop: the escape limit, but no lower than c0 and never within ESCAPE_SLACK
      of touching.
    - ``creep_back(c0)``: the clearance a slow reversing move must be back at by the time
      it could stop (ESCAPE_SLACK more than now); ``back_out(c0)``: at the end of the
      scored horizon (ESCAPE_GAIN more), unless it goes back along the plan.
    - ``recovery(c0)``: a recovery's motion (rotate_recovery, back_up): 0, or from inside
      the padding ESCAPE_TOL lower but not past the unpadded edge, and never more than
      ESCAPE_SLACK below c0.
    - ``rotation(c0)``: the in-place turn to the goal heading: ESCAPE_SLACK below
      min(c0, 0).
    """

    padding: float = 0.0     # [m] footprint_padding
    normal = 0.0

    def escape(self, floor):
        if self.padding <= 0.0:
            return floor - ESCAPE_TOL
        return max(floor - ESCAPE_TOL, min(-self.padding, floor - ESCAPE_SLACK))

    def escape_floor(self, c0, previous):
        floor = min(c0, 0.0)
        if previous is not None:
            floor = max(floor, previous)
        if self.escape(floor) > c0:
            floor = c0 + ESCAPE_TOL - ESCAPE_SLACK
            if self.escape(floor) > c0 - ESCAPE_SLACK + 1e-9:
                floor = c0
        return floor

    def creep(self, floor, c0):
        return max(self.escape(floor), min(c0, ESCAPE_SLACK))

    @staticmethod
    def creep_back(c0):
        return c0 + ESCAPE_SLACK

    @staticmethod
    def back_out(c0):
        return c0 + ESCAPE_GAIN

    def recovery(self, c0):
        return min(0.0, max(c0 - ESCAPE_TOL, -self.padding), c0 - ESCAPE_SLACK)

    @staticmethod
    def rotation(c0):
        return min(0.0, c0) - ESCAPE_SLACK
