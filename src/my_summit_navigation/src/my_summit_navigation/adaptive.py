"""Adaptive navigation parameters: slower and wider berth where the surroundings are cluttered.

Follows the race-track tutorial's section 6.3 (adaptive parameter adjustment: when the
environment's complexity is high, inflation_radius goes up and max_vel_x down, through
dynamic_reconfigure), with the complexity measured instead of given: the clutter is the
share of lethal cells (OccupancyGrid value 100, costmap_2d's LETHAL_OBSTACLE) among the
local costmap's cells whose centres lie within a radius of the robot. The switch between
the two profiles is a two-state machine (a Schmitt trigger) with a minimum dwell time:

- open -> cluttered when clutter >= enter, cluttered -> open when clutter <= leave, with
  leave < enter, so a clutter that hovers between the two thresholds changes nothing;
- no switch sooner than min_dwell seconds after the previous one, so a clutter that
  crosses both thresholds back and forth (noise on a boundary) switches at most once per
  min_dwell.

The scale of the share: an obstacle layer marks the cells the laser hits, so a wall is a
line one cell thick, and a wall 1 m from the robot is ~2 % of a 1.5 m circle. Measured on
the race track (0.05 m cells, 1.5 m): ~0.04 on its 2-3 m wide road, 0.06-0.07 in the
narrow section and the chicane, 0.02 on open ground; the course building stays below
0.025. Hence the defaults enter 0.055 / leave 0.04.

The ROS adapter (scripts/adaptive_params) reads the costmap and the robot pose, asks
``Hysteresis.update`` at a fixed rate and sends the profile of each new state to
move_base's dynamic_reconfigure servers. Nothing here imports rospy.
"""
import math
from dataclasses import dataclass

import numpy as np

LETHAL = 100            # OccupancyGrid value of a lethal cell (costmap_2d's 254 as published)
OPEN, CLUTTERED = "open", "cluttered"


class AdaptiveError(ValueError):
    """A configuration the switch cannot run with; the message names the parameter."""


def clutter(grid, resolution, origin_xy, robot_xy, radius):
    """Share (0-1) of lethal cells among the cells of grid ((H, W) OccupancyGrid values,
    row 0 = lowest y; cell side resolution [m]; lower-left corner at origin_xy [m]) whose
    centres lie within radius [m] of robot_xy [m]; None when no such cell is in the grid
    (the robot is off the costmap)."""
    h, w = grid.shape
    # column and row ranges of the radius' bounding box, clipped to the grid
    cx = (robot_xy[0] - origin_xy[0]) / resolution - 0.5   # robot in cell-centre coordinates
    cy = (robot_xy[1] - origin_xy[1]) / resolution - 0.5
    r = radius / resolution
    c0, c1 = max(0, int(math.floor(cx - r))), min(w, int(math.ceil(cx + r)) + 1)
    r0, r1 = max(0, int(math.floor(cy - r))), min(h, int(math.ceil(cy + r)) + 1)
    if c0 >= c1 or r0 >= r1:
        return None
    cols = np.arange(c0, c1) - cx
    rows = np.arange(r0, r1) - cy
    inside = rows[:, None] ** 2 + cols[None, :] ** 2 <= r * r
    n = int(inside.sum())
    if n == 0:
        return None
    return float(np.count_nonzero(grid[r0:r1, c0:c1][inside] == LETHAL)) / n


@dataclass
class Hysteresis:
    """The open / cluttered switch.

    enter: clutter (0-1) at or above which the open state turns cluttered;
    leave: clutter at or below which the cluttered state turns open (< enter);
    min_dwell: least time [s] between two switches (and from the start to the first).
    """

    enter: float = 0.055
    leave: float = 0.04
    min_dwell: float = 5.0
    state: str = OPEN
    since: float = None      # [s] time of the last switch (or of the first update)

    def __post_init__(self):
        for name in ("enter", "leave"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and 0.0 <= v <= 1.0):
                raise AdaptiveError(f"~{name}_clutter = {v!r}: must be a share between 0 and 1")
        if not self.leave < self.enter:
            raise AdaptiveError(f"~leave_clutter ({self.leave}) must be below ~enter_clutter ({self.enter}): "
                                "the gap between them is what keeps the switch from flapping")
        if not (math.isfinite(self.min_dwell) and self.min_dwell >= 0.0):
            raise AdaptiveError(f"~min_dwell = {self.min_dwell!r}: must be a time >= 0 [s]")
        if self.state not in (OPEN, CLUTTERED):
            raise AdaptiveError(f"state {self.state!r}: must be {OPEN!r} or {CLUTTERED!r}")

    def update(self, t, value):
        """Feed the clutter value (0-1, or None: no reading, nothing changes) at time t [s];
        returns the new state when this call switches, else None."""
        if self.since is None:
            self.since = t
        if value is None or t - self.since < self.min_dwell:
            return None
        if self.state == OPEN and value >= self.enter:
            self.state = CLUTTERED
        elif self.state == CLUTTERED and value <= self.leave:
            self.state = OPEN
        else:
            return None
        self.since = t
        return self.state


def cluttered_profile(open_profile, max_vel_x, inflation_radius):
    """The cluttered profile from the open one, both {server: {parameter: value}}: each
    "max_vel_x" [m/s] lowered to max_vel_x, each "inflation_radius" [m] raised to
    inflation_radius, never the other way (a value that would drive faster or closer
    keeps the open one). Returns (profile, [a note for each value kept])."""
    wanted = {"max_vel_x": (max_vel_x, min, "above"), "inflation_radius": (inflation_radius, max, "below")}
    out, notes = {}, []
    for server, values in open_profile.items():
        out[server] = {}
        for name, open_value in values.items():
            value, pick, side = wanted[name]
            out[server][name] = pick(value, open_value)
            if out[server][name] != value:
                notes.append(f"~cluttered_{name} {value:g} is {side} {server}'s {name} {open_value:g}: "
                             f"the open value is kept")
    return out, notes
