"""What the global planners share: their result, the plan's endpoints, and a start or a
goal in forbidden cells.

``PlanResult``: what a global planner's make_plan returns (navfn, global_planner,
carrot_planner). ``plan_endpoints``: the start and goal cells of a request, or why it
is unusable. ``start_region``: the forbidden cells a plan may cross to leave the region
the start lies in (navfn's and global_planner's deliberate difference, navfn.py's
docstring). ``_nearest_reached``: navfn_ros's default_tolerance search;
``_why_unreachable``: the reason a search found no plan. ``path_length`` [m].
"""
import math
from dataclasses import dataclass, field

import numpy as np

from .cost_values import INSCRIBED_INFLATED_OBSTACLE, LETHAL_OBSTACLE, NO_INFORMATION
from summit_nav_common.grid_kernels import components8, distance_transform

NEIGHBOURS = ((1, 0), (-1, 0), (0, 1), (0, -1), (1, 1), (-1, 1), (1, -1), (-1, -1))
POT_HIGH = 1.0e10      # potential of an unreached cell
START_REGION_SLACK = 4    # [cells] start_region spreads at least this far from the start
START_REGION_MAX = 200    # [cells] a start deeper than this in a forbidden region opens all of it
_NEIGHBOUR_DX = np.array([dx for dx, _ in NEIGHBOURS])
_NEIGHBOUR_DY = np.array([dy for _, dy in NEIGHBOURS])


@dataclass
class PlanResult:
    """What make_plan returns.

    path: (N, 2) world points [m] from start to goal, or None; reason: '' on success,
    else why there is no plan; goal: the goal actually planned to (x, y) [m] (differs
    from the request when default_tolerance was used); length [m]; potential: (H, W)
    float potential (POT_HIGH where unreached) when visualize_potential, else None.
    """

    path: np.ndarray = None
    reason: str = ""
    goal: tuple = None
    length: float = 0.0
    potential: np.ndarray = field(default=None, repr=False)

    @property
    def ok(self):
        return self.path is not None


def path_length(path):
    """Length [same unit as path] of a polyline (N, 2)."""
    p = np.asarray(path, dtype=np.float64)
    if len(p) < 2:
        return 0.0
    return float(np.hypot(*np.diff(p, axis=0).T).sum())


def plan_endpoints(costmap, start, goal):
    """(start cell, goal cell, '') of a plan request on costmap, or (None, None, why) when
    an end is not a finite point, is off the costmap, or the start is in a lethal cell.
    The global planners' common input checks (navfn's and global_planner's texts)."""
    for what, p in (("start", start), ("goal", goal)):
        if len(p) < 2 or not all(math.isfinite(float(v)) for v in p[:2]):
            return None, None, f"{what} {tuple(p)} is not a finite point"
    sc = costmap.world_to_map(start[0], start[1])
    if sc is None:
        return None, None, f"start ({start[0]:.2f}, {start[1]:.2f}) is off the costmap"
    gc = costmap.world_to_map(goal[0], goal[1])
    if gc is None:
        return None, None, f"goal ({goal[0]:.2f}, {goal[1]:.2f}) is off the costmap"
    if costmap.data[sc[1], sc[0]] == LETHAL_OBSTACLE:
        return None, None, "start is in a lethal cell (the robot is in collision)"
    return sc, gc, ""


def start_region(forbidden, lethal, sc):
    """(H, W) bool: the forbidden, non-lethal cells a plan may cross to leave the forbidden
    region the start cell sc (x, y) lies in: those no deeper in it than the start (depth:
    the distance to the nearest passable cell) and within max(START_REGION_SLACK, twice
    that depth) cells of the start (8-connected, through such cells). The way out never
    needs deeper cells, while crossing a wall between its cells does (the wall's core is
    the deepest part of its inscribed band). With no passable cell within START_REGION_MAX
    cells (a robot deep in unknown space) the whole connected region."""
    blocked = forbidden & ~lethal
    h, w = blocked.shape
    if forbidden.all():
        depth0 = math.inf
    else:
        depth = distance_transform(forbidden.astype(np.uint8))
        depth0 = float(depth[sc[1], sc[0]])
    if depth0 > START_REGION_MAX:
        # the 8-connected cells of the start's own kind (blocked or not) joined to it
        same = blocked == blocked[sc[1], sc[0]]
        labels = components8(same)
        return labels == labels[sc[1], sc[0]]
    # Breadth-first from the start through the shallow cells, one ring of 8-neighbours per
    # step; the frontier is a set (each cell once), so the work is that of the cells opened.
    shallow = (blocked & (depth <= depth0 + 1e-6)).ravel()
    region = np.zeros(h * w, bool)
    front = np.array([sc[1] * w + sc[0]], dtype=np.int64)
    region[front] = True
    for _ in range(max(START_REGION_SLACK, int(math.ceil(2.0 * depth0)))):
        ny = (front[:, None] // w + _NEIGHBOUR_DY).ravel()
        nx = (front[:, None] % w + _NEIGHBOUR_DX).ravel()
        ok = (ny >= 0) & (ny < h) & (nx >= 0) & (nx < w)
        cand = np.unique(ny[ok] * w + nx[ok])
        front = cand[shallow[cand] & ~region[cand]]
        if len(front) == 0:
            break
        region[front] = True
    return region.reshape(h, w)


def _nearest_reached(pot, costmap, goal, tol):
    """navfn_ros: the reached cell nearest the goal within a tol [m] square, or None."""
    res = costmap.resolution
    gx = (goal[0] - costmap.origin_x) / res - 0.5
    gy = (goal[1] - costmap.origin_y) / res - 0.5
    r = tol / res
    x0, x1 = max(0, int(math.ceil(gx - r))), min(costmap.size_x - 1, int(math.floor(gx + r)))
    y0, y1 = max(0, int(math.ceil(gy - r))), min(costmap.size_y - 1, int(math.floor(gy + r)))
    if x1 < x0 or y1 < y0:
        return None
    sub = pot[y0:y1 + 1, x0:x1 + 1]
    yy, xx = np.mgrid[y0:y1 + 1, x0:x1 + 1]
    d2 = (xx - gx) ** 2 + (yy - gy) ** 2
    d2 = np.where(sub < POT_HIGH, d2, np.inf)
    k = int(np.argmin(d2))
    if not np.isfinite(d2.flat[k]):
        return None
    return int(xx.flat[k]), int(yy.flat[k])


def _why_unreachable(goal_cost, allow_unknown, tol, pot=None, resolution=None):
    """Why no plan: the goal's cell, else the start's side. pot: the potential of the
    failed search (every cell reachable from the start settled), for the size of the
    start's free region: a few cells mean the robot is boxed in (e.g. by marks that
    should have been cleared), a large one that the goal is cut off."""
    extra = f" and no reachable cell within default_tolerance {tol:.2f} m" if tol > 0 else ""
    if goal_cost == LETHAL_OBSTACLE:
        return "goal is in an obstacle (lethal cell)" + extra
    if goal_cost == INSCRIBED_INFLATED_OBSTACLE:
        return "goal is too close to an obstacle (inscribed cell)" + extra
    if goal_cost == NO_INFORMATION and not allow_unknown:
        return "goal is in unknown space and allow_unknown is false" + extra
    region = ""
    if pot is not None and resolution is not None:
        n = int(np.count_nonzero(pot < POT_HIGH))
        region = f" (the start's free region: {n} cells, {n * resolution ** 2:.2f} m^2)"
    return "no path: the goal is not reachable from the start" + region + extra
