"""global_planner/GlobalPlanner: potential expansion (Dijkstra or A*) + path extraction.

Reference: ROS 1 navigation ``global_planner`` (planner_core.cpp, dijkstra.cpp,
astar.cpp, quadratic_calculator.cpp, potential_calculator.h, gradient_path.cpp,
grid_path.cpp, orientation_filter.cpp, cfg/GlobalPlanner.cfg) and wiki.ros.org/global_planner
for the parameters; the potential is navfn's navigation function (Konolige 2000, "A
Gradient Method for Realtime Robot Control"), a fast-marching-like wavefront on the
4-connected grid.

The algorithm, in the order it runs (GlobalPlanner.make_plan):
1. Cell costs: a costmap cost c below ``lethal_cost - 1`` costs
   ``min(c * cost_factor + neutral_cost, lethal_cost - 1)`` (Dijkstra: the expander's
   getCost) or ``min(c + neutral_cost, lethal_cost - 1)`` (A*: AStarExpansion adds the
   raw cost to neutral_cost, cost_factor does not apply); unknown cells (255) the same
   when allow_unknown; every other cell is forbidden. With the defaults (253, 50, 3.0)
   Dijkstra weighs every cost from 68 up the same 252: it keeps to the middle of a
   corridor, ~0.6 m off the walls with the course's inflation, and plans paths ~3 %
   longer than the shortest free route; A*'s gentler weights (up to 5 x neutral_cost
   only at cost 202) give paths ~1 % longer. outline_map makes the costmap's border
   cells forbidden.
2. Potential from the robot towards the goal (expand): cells are accepted in order of
   potential (Dijkstra, use_dijkstra) or potential + a distance-to-goal heuristic (A*);
   each accepted cell updates its 4 neighbours. A cell's potential comes from its four
   neighbours (the potential calculators): the simple update is the lowest neighbour +
   the cell cost; the quadratic update (use_quadratic) is navfn's planar-wave update
   from the lowest horizontal and the lowest vertical neighbour, which makes the
   potential close to the Euclidean cost-weighted distance rather than the Manhattan
   one. The expansion stops when the goal cell is accepted. Without old_navfn_behavior
   the start is sub-cell precise (the four cells around the robot's point are seeded with
   their cost x distance to it) and, after the expansion, the unreached passable cells
   within CLEAR_ENDPOINT of the goal cell get a potential from their neighbours
   (clearEndpoint), so the path can start at the goal point.
3. Goal: the goal cell if it was reached; else, with a tolerance > 0, the reached cell
   closest to the goal within the tolerance square (as our NavFn; the real node ignores
   its tolerance).
4. Path, from the goal down to the robot: gradient descent (GradientPath: steps of
   PATH_STEP cells along the bilinearly interpolated, per-cell normalized gradient; a
   grid step to the lowest 8-neighbour where some neighbour is unreached or the path
   oscillates), or with use_grid_path a steepest-descent path over cell centres
   (GridPath). Each point lies in a reached cell: the path never enters a forbidden cell.
5. Orientations (OrientationFilter, orientation_mode / orientation_window_size): every
   pose but the goal gets the path's direction (Forward; Backward, Leftward, Rightward
   turn it by pi, -pi/2, +pi/2), or a blend from the start yaw to the goal yaw
   (Interpolate), or Forward up to the last straight stretch and a blend over it
   (ForwardThenInterpolate); None leaves yaw 0. The last pose has the goal's yaw. The
   real orientation_mode default is the .cfg's Forward (1): dynamic_reconfigure sets it.

The hot loops (expansion, the fill around the goal, both path makers) are C
(summit_nav_common/csrc/global_planner.c, built by catkin, called through ctypes: no numba
and its LLVM in move_base): ``expand``, ``clear_endpoint``, ``gradient_path`` and
``grid_path``. Their Python twins (``_expand``, ``_clear_endpoint``, ``_gradient_path``,
``_grid_path``) are the C's bit-for-bit test oracle; ``potential_reference`` is the slow,
obvious expansion kept as the oracle of both.

Deliberate differences from the real planner:
- A* has the real AStarExpansion's cell costs (raw cost + neutral_cost; the real one
  passes that sum as an unsigned char, so from cost 206 up it wraps round to a small
  cost: here it is capped at lethal_cost - 1 as Dijkstra's), the same potential update
  as Dijkstra and an admissible heuristic (HEURISTIC_WEIGHT x neutral_cost x Euclidean
  distance), so it plans the Dijkstra path of those costs (to within the update's order
  dependence) and expands fewer cells. (The real one never lowers a potential once set
  and weighs neutral_cost x the Manhattan distance, which overestimates: its paths are
  not the Dijkstra paths of any cost.)
- Dijkstra accepts cells in exact potential order (a binary heap), not in navfn's
  threshold buckets.
- The precise start seeds the four cells around the robot with cost x distance; the
  start and goal cells are the cells that contain the points (the real code truncates
  the half-cell-shifted coordinates, taking the cell below and left half the time).
- make_plan follows our NavFn's contract: the same error texts, default_tolerance
  honoured, and a robot whose centre is in a forbidden but not lethal cell (inscribed, or
  unknown without allow_unknown) gets a plan out of that region by a short way
  (navfn.start_region; the real planner frees the robot's cell only, in the shared
  costmap). The costmap is never modified.
- The fill around the goal (clearEndpoint) covers passable cells only, at their cell
  cost (the real one fills obstacle cells too, at raw cost + neutral_cost), so no path
  point can be pulled into an obstacle.
- When the gradient descent fails the grid path is used (as the real planner once did); ForwardThenInterpolate blends from the start of the straight stretch
  (the real filter offsets the blend by that index).
"""
import ctypes
import math
from dataclasses import dataclass, field

import numpy as np

from .cost_values import LETHAL_OBSTACLE, NO_INFORMATION
from .global_plan import (POT_HIGH, PlanResult, _nearest_reached, _why_unreachable, path_length, plan_endpoints,
                          start_region)
from .param_reader import Schema

from summit_nav_common.native import library, take_points

PATH_STEP = 0.5          # [cells] gradient-descent step (GradientPath's pathStep)
CLEAR_ENDPOINT = 2       # [cells] half-width of the square around the goal filled in after expansion
# The quadratic potential update: with ta the lower and tc the higher of the lowest
# horizontal and lowest vertical neighbour, hf the cell cost and d = (tc - ta) / hf < 1,
# the new potential is ta + hf * v(d), v a quadratic fit on [0, 1] of the exact planar
# wave solution (d + sqrt(2 - d^2)) / 2 (navfn's coefficients); for d >= 1 it is ta + hf.
QUAD_A, QUAD_B, QUAD_C = -0.2301, 0.5307, 0.7040
# A* heuristic = this x neutral_cost x Euclidean distance to the goal [cells]. The
# potential grows by at least QUAD_C x cost per axis step (a diagonal wave), the
# heuristic falls by at most this x neutral_cost: it never overestimates what is left.
# (With the quadratic update a cell's potential also depends on which of its neighbours
# were reached before it, so A*'s order moves potentials a little: on willow-full's
# costmap the goal's by <= 1 %, the plan's cost by <= 0.2 %.)
HEURISTIC_WEIGHT = QUAD_C
ASTAR_COST_FACTOR = 1.0  # AStarExpansion: raw costmap cost + neutral_cost (cost_factor is Dijkstra's only)
STRAIGHT_ANGLE = 0.35    # [rad] ForwardThenInterpolate: headings within this of the last one are "straight"
HEAP_CAPACITY = 1 << 14  # initial heap size [entries]; it doubles when full

ORIENTATION_MODES = ("None", "Forward", "Interpolate", "ForwardThenInterpolate", "Backward", "Leftward",
                     "Rightward")
NONE, FORWARD, INTERPOLATE, FORWARD_THEN_INTERPOLATE, BACKWARD, LEFTWARD, RIGHTWARD = range(7)
# The yaw the pose gets relative to the path's direction, per mode that follows the path.
_MODE_TURN = {FORWARD: 0.0, BACKWARD: math.pi, LEFTWARD: -math.pi / 2, RIGHTWARD: math.pi / 2}


@dataclass
class GlobalPlannerConfig:
    """global_planner's ROS parameters (GlobalPlanner namespace), real names and defaults."""

    allow_unknown: bool = True            # plan through unknown cells (255)
    default_tolerance: float = 0.0        # [m] accept a reachable goal this close to the goal
    visualize_potential: bool = False     # keep the potential (also kept when publish_potential)
    use_dijkstra: bool = True             # Dijkstra expansion; false: A*
    use_quadratic: bool = True            # quadratic (two-neighbour) potential update; false: lowest neighbour + cost
    use_grid_path: bool = False           # path over cell centres; false: gradient descent
    old_navfn_behavior: bool = False      # navfn's conventions: whole cells, no precise start / endpoint fill
    planner_window_x: float = 0.0         # [m] read and unused, as in the real planner
    planner_window_y: float = 0.0         # [m]
    publish_scale: int = 100              # ~potential: the highest potential maps to this
    outline_map: bool = True              # make the costmap's border cells forbidden
    # dynamic_reconfigure (GlobalPlanner.cfg), with its ranges
    lethal_cost: int = 253                # [1, 255] costs from lethal_cost - 1 up are forbidden
    neutral_cost: int = 50                # [1, 255] potential per cell of free space
    cost_factor: float = 3.0              # [0.01, 5.0] potential per unit of costmap cost (Dijkstra only)
    publish_potential: bool = True        # publish ~potential (the node's job; here: keep it)
    orientation_mode: int = 1             # [0, 6] ORIENTATION_MODES; the .cfg's default is Forward
    orientation_window_size: int = 1      # [1, 255] [poses] either side for the path direction


_RANGES = {"lethal_cost": (1, 255), "neutral_cost": (1, 255), "cost_factor": (0.01, 5.0),
           "orientation_mode": (0, len(ORIENTATION_MODES) - 1), "orientation_window_size": (1, 255),
           "default_tolerance": (0.0, math.inf), "publish_scale": (1, 127)}
SCHEMA = Schema.of(GlobalPlannerConfig, **{k: dict(lo=lo, hi=hi) for k, (lo, hi) in _RANGES.items()})


@dataclass
class GlobalPlanResult(PlanResult):
    """A PlanResult with the orientation filter's yaws (N,) [rad], one per path point."""

    yaws: np.ndarray = field(default=None, repr=False)


def planner_costs(costs, lethal_cost=253, neutral_cost=50, cost_factor=3.0, allow_unknown=True):
    """Costmap costs (H, W) uint8 -> the planner's cell costs (H, W) float64, inf = forbidden."""
    c = np.arange(256, dtype=np.float64)
    lut = np.minimum(c * cost_factor + neutral_cost, lethal_cost - 1.0)
    passable = c < lethal_cost - 1
    if allow_unknown:
        passable[NO_INFORMATION] = True
    lut[~passable] = np.inf
    return lut[np.asarray(costs, dtype=np.uint8)]


# ----- the expansion ------------------------------------------------------------------------
# The kernels' Python (the C's oracle): libm's hypot through np.hypot, as the C (math.hypot
# rounds differently in ~0.5 % of cases).

def _update(pot, cost, n, nx, ny, quadratic):
    """New potential of flat cell n from its four neighbours (the potential calculators)."""
    x = n % nx
    y = n // nx
    left = pot[n - 1] if x > 0 else POT_HIGH
    right = pot[n + 1] if x < nx - 1 else POT_HIGH
    down = pot[n - nx] if y > 0 else POT_HIGH
    up = pot[n + nx] if y < ny - 1 else POT_HIGH
    tc = min(left, right)
    ta = min(down, up)
    hf = cost[n]
    if not quadratic:
        return min(ta, tc) + hf
    dc = tc - ta
    if dc < 0.0:
        dc = -dc
        ta = tc
    if dc >= hf:
        return ta + hf
    d = dc / hf
    return ta + hf * (QUAD_A * d * d + QUAD_B * d + QUAD_C)


def _heap_push(keys, vals, size, key, val):
    """Push onto the binary min-heap (keys, vals) holding size entries; returns the arrays
    (new ones when they had to grow)."""
    if size == keys.shape[0]:
        nk = np.empty(2 * size, keys.dtype)
        nv = np.empty(2 * size, vals.dtype)
        nk[:size] = keys
        nv[:size] = vals
        keys, vals = nk, nv
    i = size
    while i > 0:
        parent = (i - 1) >> 1
        if keys[parent] <= key:
            break
        keys[i] = keys[parent]
        vals[i] = vals[parent]
        i = parent
    keys[i] = key
    vals[i] = val
    return keys, vals


def _heap_pop(keys, vals, size):
    """Remove the smallest entry of the heap of size entries; returns its value."""
    top = vals[0]
    size -= 1
    key, val = keys[size], vals[size]
    i = 0
    while True:
        c = 2 * i + 1
        if c >= size:
            break
        if c + 1 < size and keys[c + 1] < keys[c]:
            c += 1
        if keys[c] >= key:
            break
        keys[i] = keys[c]
        vals[i] = vals[c]
        i = c
    if size > 0:
        keys[i] = key
        vals[i] = val
    return top


def _expand(cost, nx, ny, seeds, seed_pots, goal, heuristic, quadratic, pot):
    """Propagate the potential from the seed cells until goal is accepted (goal -1: until
    every reachable cell is). cost: (nx*ny,) float, inf forbidden; pot: (nx*ny,) filled
    with POT_HIGH, written in place; heuristic: potential per cell of distance to the goal
    (0: Dijkstra). Returns (goal accepted, number of cells accepted)."""
    closed = np.zeros(nx * ny, np.uint8)
    keys = np.empty(HEAP_CAPACITY, np.float64)
    vals = np.empty(HEAP_CAPACITY, np.int64)
    size = 0
    if goal < 0:
        heuristic = 0.0  # no goal: plain Dijkstra
    gx = goal % nx
    gy = goal // nx
    for k in range(seeds.shape[0]):
        s = seeds[k]
        if seed_pots[k] < pot[s]:
            pot[s] = seed_pots[k]
            h = heuristic * np.hypot(s % nx - gx, s // nx - gy) if heuristic > 0.0 else 0.0
            keys, vals = _heap_push(keys, vals, size, pot[s] + h, s)
            size += 1
    accepted = 0
    while size > 0:
        n = _heap_pop(keys, vals, size)
        size -= 1
        if closed[n]:
            continue  # an older, higher entry of a cell accepted before
        closed[n] = 1
        accepted += 1
        if n == goal:
            return True, accepted
        x = n % nx
        y = n // nx
        for k in range(4):
            if k == 0:
                if x == 0:
                    continue
                m = n - 1
            elif k == 1:
                if x == nx - 1:
                    continue
                m = n + 1
            elif k == 2:
                if y == 0:
                    continue
                m = n - nx
            else:
                if y == ny - 1:
                    continue
                m = n + nx
            if closed[m] or not cost[m] < np.inf:
                continue
            p = _update(pot, cost, m, nx, ny, quadratic)
            if p < pot[m]:
                pot[m] = p
                h = heuristic * np.hypot(m % nx - gx, m // nx - gy) if heuristic > 0.0 else 0.0
                keys, vals = _heap_push(keys, vals, size, p + h, m)
                size += 1
    return False, accepted


def _clear_endpoint(cost, nx, ny, pot, gx, gy, half, quadratic):
    """Give the unreached passable cells within half cells of (gx, gy) a potential from their
    neighbours (in x-major order, each fill seeing the earlier ones)."""
    for i in range(-half, half + 1):
        for j in range(-half, half + 1):
            x, y = gx + i, gy + j
            if x < 0 or y < 0 or x >= nx or y >= ny:
                continue
            n = y * nx + x
            if pot[n] < POT_HIGH or not cost[n] < np.inf:
                continue
            p = _update(pot, cost, n, nx, ny, quadratic)
            if p < POT_HIGH:
                pot[n] = p


def potential_reference(cost, seeds, goal=None, heuristic=0.0, quadratic=True):
    """Slow, obvious expansion (the test oracle for expand).

    cost: (H, W) cell costs, inf forbidden; seeds: {(x, y): potential}; goal: (x, y) to
    stop at, or None for every reachable cell; heuristic: potential per cell of Euclidean
    distance to the goal (0: Dijkstra). Returns ((H, W) potentials, POT_HIGH unreached,
    (H, W) bool accepted).
    """
    import heapq
    cost = [[float(v) for v in row] for row in np.asarray(cost)]
    h, w = len(cost), len(cost[0])
    pot = [[POT_HIGH] * w for _ in range(h)]
    done = [[False] * w for _ in range(h)]

    def at(x, y):
        return pot[y][x] if 0 <= x < w and 0 <= y < h else POT_HIGH

    def dist_to_goal(x, y):
        return 0.0 if goal is None or heuristic == 0 else heuristic * math.hypot(x - goal[0], y - goal[1])

    def update(x, y):
        hf = cost[y][x]
        horizontal, vertical = min(at(x - 1, y), at(x + 1, y)), min(at(x, y - 1), at(x, y + 1))
        low, high = min(horizontal, vertical), max(horizontal, vertical)
        if not quadratic or high - low >= hf:
            return low + hf
        d = (high - low) / hf
        return low + hf * (QUAD_A * d * d + QUAD_B * d + QUAD_C)

    queue = []
    for (x, y), p in seeds.items():
        pot[y][x] = min(pot[y][x], p)
        heapq.heappush(queue, (pot[y][x] + dist_to_goal(x, y), x, y))
    while queue:
        _, x, y = heapq.heappop(queue)
        if done[y][x]:
            continue
        done[y][x] = True
        if goal is not None and (x, y) == tuple(goal):
            break
        for nxt in ((x - 1, y), (x + 1, y), (x, y - 1), (x, y + 1)):
            mx, my = nxt
            if 0 <= mx < w and 0 <= my < h and not done[my][mx] and math.isfinite(cost[my][mx]):
                p = update(mx, my)
                if p < pot[my][mx]:
                    pot[my][mx] = p
                    heapq.heappush(queue, (p + dist_to_goal(mx, my), mx, my))
    return np.array(pot), np.array(done)


# ----- the path makers ----------------------------------------------------------------------

def _append(buf, n, x, y):
    if n == buf.shape[0]:
        nb = np.empty((2 * n, 2), buf.dtype)
        nb[:n] = buf
        buf = nb
    buf[n, 0] = x
    buf[n, 1] = y
    return buf


def _grad(pot, nx, ny, n):
    """Unit downhill gradient (gx, gy) of reached cell n from its reached 4-neighbours (a
    neighbour off the grid counts as unreached)."""
    x = n % nx
    y = n // nx
    p = pot[n]
    gx = 0.0
    gy = 0.0
    if x > 0 and pot[n - 1] < POT_HIGH:
        gx += pot[n - 1] - p
    if x < nx - 1 and pot[n + 1] < POT_HIGH:
        gx += p - pot[n + 1]
    if y > 0 and pot[n - nx] < POT_HIGH:
        gy += pot[n - nx] - p
    if y < ny - 1 and pot[n + nx] < POT_HIGH:
        gy += p - pot[n + nx]
    norm = np.hypot(gx, gy)
    if norm > 0.0:
        return gx / norm, gy / norm
    return 0.0, 0.0


def _lowest_neighbour(pot, nx, ny, cx, cy):
    """The 8-neighbour of cell (cx, cy) with the lowest potential below its own, else (cx, cy)."""
    best = pot[cy * nx + cx]
    bx, by = cx, cy
    for dy in range(-1, 2):
        for dx in range(-1, 2):
            x, y = cx + dx, cy + dy
            if (dx or dy) and 0 <= x < nx and 0 <= y < ny and pot[y * nx + x] < best:
                best = pot[y * nx + x]
                bx, by = x, y
    return bx, by


def _gradient_path(pot, nx, ny, sx, sy, gx, gy, step, max_cycles):
    """Descend the potential from (gx, gy) to (sx, sy) [cells, centres at integers].

    Returns ((M, 2) points from the goal to the start, ok)."""
    buf = np.empty((256, 2), np.float64)
    n = 0
    px, py = gx, gy
    for _ in range(max_cycles):
        if abs(px - sx) < 0.5 and abs(py - sy) < 0.5:
            buf = _append(buf, n, sx, sy)
            return buf[:n + 1], True
        buf = _append(buf, n, px, py)
        n += 1
        cx = int(math.floor(px + 0.5))
        cy = int(math.floor(py + 0.5))
        if cx < 1 or cy < 1 or cx > nx - 2 or cy > ny - 2:
            return buf[:n], False
        near_unreached = False
        for dy in range(-1, 2):
            for dx in range(-1, 2):
                if pot[(cy + dy) * nx + cx + dx] >= POT_HIGH:
                    near_unreached = True
        oscillating = n > 2 and buf[n - 1, 0] == buf[n - 3, 0] and buf[n - 1, 1] == buf[n - 3, 1]
        if near_unreached or oscillating:
            bx, by = _lowest_neighbour(pot, nx, ny, cx, cy)
            if bx == cx and by == cy:
                return buf[:n], False
            px, py = float(bx), float(by)
            continue
        # bilinear interpolation of the four cells' gradients around the point
        ix = int(math.floor(px))
        iy = int(math.floor(py))
        fx, fy = px - ix, py - iy
        i00 = iy * nx + ix
        g00 = _grad(pot, nx, ny, i00)
        g10 = _grad(pot, nx, ny, i00 + 1)
        g01 = _grad(pot, nx, ny, i00 + nx)
        g11 = _grad(pot, nx, ny, i00 + nx + 1)
        vx = (1 - fy) * ((1 - fx) * g00[0] + fx * g10[0]) + fy * ((1 - fx) * g01[0] + fx * g11[0])
        vy = (1 - fy) * ((1 - fx) * g00[1] + fx * g10[1]) + fy * ((1 - fx) * g01[1] + fx * g11[1])
        norm = np.hypot(vx, vy)
        if norm == 0.0:
            return buf[:n], False
        px += step * vx / norm
        py += step * vy / norm
    return buf[:n], False


def _grid_path(pot, nx, ny, sx, sy, gx, gy, max_cycles):
    """Steepest descent over 8-neighbours from cell (gx, gy) to cell (sx, sy).

    Returns ((M, 2) cell coordinates from the goal to the start, ok). A local minimum next
    to the start cell (a precise-start seed) steps onto the start cell."""
    buf = np.empty((256, 2), np.float64)
    n = 0
    x, y = gx, gy
    buf = _append(buf, n, x, y)
    n += 1
    for _ in range(max_cycles):
        if x == sx and y == sy:
            return buf[:n], True
        bx, by = _lowest_neighbour(pot, nx, ny, x, y)
        if bx == x and by == y:
            if abs(x - sx) <= 1 and abs(y - sy) <= 1:
                bx, by = sx, sy
            else:
                return buf[:n], False
        x, y = bx, by
        buf = _append(buf, n, x, y)
        n += 1
    return buf[:n], False


# ----- the kernels, compiled (csrc/global_planner.c): the Python ones' arguments and results ---

def _check_grid(what, nx, ny, *grids):
    if nx < 1 or ny < 1:
        raise ValueError(f"{what}: a grid of {nx} x {ny} cells")
    for g in grids:
        if g.dtype != np.float64 or g.ndim != 1 or g.size != nx * ny:
            raise ValueError(f"{what}: expected flat float64 grids of {nx} x {ny} cells, got {g.dtype} {g.shape}")


def expand(cost, nx, ny, seeds, seed_pots, goal, heuristic, quadratic, pot):
    """_expand in C: pot (flat float64, POT_HIGH everywhere) written in place; returns
    (goal accepted, number of cells accepted)."""
    _check_grid("expand", nx, ny, cost, pot)
    seeds = np.ascontiguousarray(seeds, dtype=np.int64)
    seed_pots = np.ascontiguousarray(seed_pots, dtype=np.float64)
    if seeds.shape != seed_pots.shape or ((seeds < 0) | (seeds >= nx * ny)).any():
        raise ValueError(f"expand: seeds {seeds} with potentials {seed_pots} on {nx} x {ny} cells")
    accepted = ctypes.c_int64(0)
    reached = library().snc_gp_expand(cost, nx, ny, seeds, seed_pots, seeds.size, int(goal), float(heuristic),
                                      int(bool(quadratic)), pot, ctypes.byref(accepted))
    if reached < 0:
        raise MemoryError("expand: out of memory")
    return reached == 1, accepted.value


def clear_endpoint(cost, nx, ny, pot, gx, gy, half, quadratic):
    """_clear_endpoint in C (pot written in place)."""
    _check_grid("clear_endpoint", nx, ny, cost, pot)
    library().snc_gp_clear_endpoint(cost, nx, ny, pot, int(gx), int(gy), int(half), int(bool(quadratic)))


def gradient_path(pot, nx, ny, sx, sy, gx, gy, step, max_cycles):
    """_gradient_path in C: ((M, 2) points from the goal to the start, ok)."""
    _check_grid("gradient_path", nx, ny, pot)
    out, ok = ctypes.POINTER(ctypes.c_double)(), ctypes.c_int(0)
    n = library().snc_gp_gradient_path(pot, nx, ny, float(sx), float(sy), float(gx), float(gy), float(step),
                                       int(max_cycles), ctypes.byref(out), ctypes.byref(ok))
    return take_points(out, n, "gradient_path"), bool(ok.value)


def grid_path(pot, nx, ny, sx, sy, gx, gy, max_cycles):
    """_grid_path in C: ((M, 2) cell coordinates from the goal to the start, ok)."""
    _check_grid("grid_path", nx, ny, pot)
    if not (0 <= gx < nx and 0 <= gy < ny):
        raise ValueError(f"grid_path: goal cell ({gx}, {gy}) off the {nx} x {ny} grid")
    out, ok = ctypes.POINTER(ctypes.c_double)(), ctypes.c_int(0)
    n = library().snc_gp_grid_path(pot, nx, ny, int(sx), int(sy), int(gx), int(gy), int(max_cycles),
                                   ctypes.byref(out), ctypes.byref(ok))
    return take_points(out, n, "grid_path"), bool(ok.value)


# ----- orientations ---------------------------------------------------------------------------

def _angle_diff(a, b):
    """Shortest signed angle from a to b [rad]."""
    return (b - a + math.pi) % (2 * math.pi) - math.pi


def orientation_filter(xy, start_yaw, goal_yaw, mode=FORWARD, window=1):
    """Yaws (N,) [rad] for the path points xy (N, 2) (OrientationFilter::processPath).

    The last point keeps goal_yaw in every mode; see ORIENTATION_MODES and the module
    docstring for what the others get. window [poses]: the direction at i is that from
    point i - window to point i + window (clipped to the path).
    """
    p = np.asarray(xy, dtype=np.float64)
    n = len(p)
    yaws = np.zeros(n)
    if n == 0:
        return yaws
    yaws[-1] = goal_yaw

    def blend(first, last):
        inc = _angle_diff(yaws[first], yaws[last]) / max(1, last - first)
        blended = yaws[first] + inc * np.arange(last - first + 1)
        yaws[first:last + 1] = (blended + math.pi) % (2 * math.pi) - math.pi

    # the path's direction at every point but the last, from point i - window to i + window
    i = np.arange(n - 1)
    a, b = p[np.maximum(0, i - window)], p[np.minimum(n - 1, i + window)]
    direction = np.arctan2(b[:, 1] - a[:, 1], b[:, 0] - a[:, 0])
    if mode in _MODE_TURN:
        yaws[:-1] = (direction + _MODE_TURN[mode] + math.pi) % (2 * math.pi) - math.pi
    elif mode == INTERPOLATE:
        yaws[0] = start_yaw
        blend(0, n - 1)
    elif mode == FORWARD_THEN_INTERPOLATE:
        yaws[:-1] = direction
        i = max(0, n - 3)
        last = yaws[i]
        while i > 0 and abs(_angle_diff(yaws[i - 1], last)) <= STRAIGHT_ANGLE:
            i -= 1
        yaws[0] = start_yaw
        blend(i, n - 1)
    yaws[-1] = (goal_yaw + math.pi) % (2 * math.pi) - math.pi
    return yaws


def potential_to_occupancy(pot, publish_scale=100):
    """The ~potential grid's data: (H, W) int8, -1 where unreached, else the potential
    scaled so that the highest reached one is publish_scale (all -1 if that is 0)."""
    p = np.asarray(pot, dtype=np.float64)
    reached = p < POT_HIGH
    top = float(p[reached].max()) if reached.any() else 0.0
    out = np.full(p.shape, -1, np.int8)
    if top > 0.0:
        out[reached] = np.clip(p[reached] * publish_scale / top, 0, 127).astype(np.int8)
    return out


# ----- the planner ----------------------------------------------------------------------------

class GlobalPlanner:
    """The global_planner/GlobalPlanner (base_global_planner's makePlan, without ROS).

    config: a GlobalPlannerConfig. After each make_plan, ``potential`` holds that plan's
    (H, W) potential (POT_HIGH unreached) for ~potential, or None when neither
    visualize_potential nor publish_potential asks for it; ``cells_expanded`` counts the
    cells the expansion accepted.
    """

    KNOWN_PARAMS = frozenset(SCHEMA.known)

    def __init__(self, config=None):
        self.config = config or GlobalPlannerConfig()
        self.potential = None
        self.cells_expanded = 0
        self.notes = []   # param_reader notes about the parameters it was built from

    @classmethod
    def from_params(cls, params, where="GlobalPlanner", note_where=None):
        """A planner from the GlobalPlanner namespace's dict (SCHEMA: the real names,
        defaults and dynamic_reconfigure's ranges).

        Wrong types or values out of the real ranges raise ParamError naming
        ``where/key``; names the real planner does not read are left unread and noted in
        ``notes`` (prefixed with note_where, default where), for the node to log once.
        """
        r = SCHEMA.read(params, where, note_where)
        planner = cls(GlobalPlannerConfig(**r.values))
        planner.notes = r.notes
        return planner

    def make_plan(self, costmap, start, goal, tolerance=None):
        """Plan on costmap (a Costmap2D) from start (x, y[, yaw]) to goal (x, y[, yaw]) [m, rad]
        in the costmap's frame.

        tolerance [m]: overrides default_tolerance. Returns a GlobalPlanResult (a
        navfn.PlanResult with yaws); its reason says why there is no plan (bad or off-map
        input, start in a lethal cell, goal in an obstacle / unknown space / unreachable).
        A missing yaw counts as 0.
        """
        cfg = self.config
        tol = cfg.default_tolerance if tolerance is None else float(tolerance)
        self.potential = None
        self.cells_expanded = 0
        sc, gc, why = plan_endpoints(costmap, start, goal)
        if why:
            return GlobalPlanResult(reason=why)
        data = costmap.data
        factor = cfg.cost_factor if cfg.use_dijkstra else ASTAR_COST_FACTOR
        cost = planner_costs(data, cfg.lethal_cost, cfg.neutral_cost, factor, cfg.allow_unknown)
        if cfg.outline_map:
            cost[0, :] = cost[-1, :] = cost[:, 0] = cost[:, -1] = np.inf
        if not np.isfinite(cost[sc[1], sc[0]]):
            _open_start_region(data, cost, sc, cfg.lethal_cost - 1.0)
        ny, nx = cost.shape
        goal_passable = bool(np.isfinite(cost[gc[1], gc[0]]))
        if not goal_passable and tol <= 0:
            return GlobalPlanResult(reason=_why_unreachable(data[gc[1], gc[0]], cfg.allow_unknown, tol))

        # Continuous map coordinates, cell centres at integers (navfn's cells when old_navfn_behavior).
        res = costmap.resolution
        if cfg.old_navfn_behavior:
            s_xy, g_xy = (float(sc[0]), float(sc[1])), (float(gc[0]), float(gc[1]))
        else:
            s_xy = ((start[0] - costmap.origin_x) / res - 0.5, (start[1] - costmap.origin_y) / res - 0.5)
            g_xy = ((goal[0] - costmap.origin_x) / res - 0.5, (goal[1] - costmap.origin_y) / res - 0.5)
        seeds, seed_pots = self._seeds(cost, sc, s_xy)
        flat_cost = cost.ravel()
        pot = np.full(nx * ny, POT_HIGH)
        target_cell = gc[1] * nx + gc[0] if goal_passable else -1
        heuristic = 0.0 if cfg.use_dijkstra else HEURISTIC_WEIGHT * cfg.neutral_cost
        reached, self.cells_expanded = expand(flat_cost, nx, ny, seeds, seed_pots, target_cell,
                                              heuristic, cfg.use_quadratic, pot)
        target = gc
        if reached and not cfg.old_navfn_behavior:
            clear_endpoint(flat_cost, nx, ny, pot, gc[0], gc[1], CLEAR_ENDPOINT, cfg.use_quadratic)
        pot = pot.reshape(ny, nx)
        keep = cfg.visualize_potential or cfg.publish_potential
        self.potential = pot if keep else None
        if not reached:
            target = _nearest_reached(pot, costmap, goal, tol) if tol > 0 else None
            if target is None:
                return GlobalPlanResult(reason=_why_unreachable(data[gc[1], gc[0]], cfg.allow_unknown, tol, pot,
                                                                costmap.resolution),
                                        potential=self.potential)
            g_xy = (float(target[0]), float(target[1]))

        cells = self._path(pot, s_xy, g_xy, sc, target)
        if cells is None:
            return GlobalPlanResult(reason="no path: the descent of the potential failed",
                                    potential=self.potential)
        cells = cells[::-1]  # start -> goal
        offset = 0.0 if cfg.old_navfn_behavior else 0.5
        world = np.column_stack([costmap.origin_x + (cells[:, 0] + offset) * res,
                                 costmap.origin_y + (cells[:, 1] + offset) * res])
        if target == gc:
            goal_xy = (float(goal[0]), float(goal[1]))
            if cfg.old_navfn_behavior:
                world = np.vstack([world, [goal_xy]])  # navfn appends the goal pose itself
            else:
                world[-1] = goal_xy
        else:
            goal_xy = costmap.map_to_world(*target)
            world[-1] = goal_xy
        if not cfg.old_navfn_behavior:
            world[0] = (float(start[0]), float(start[1]))
        start_yaw = float(start[2]) if len(start) > 2 else 0.0
        goal_yaw = float(goal[2]) if len(goal) > 2 else 0.0
        yaws = orientation_filter(world, start_yaw, goal_yaw, cfg.orientation_mode, cfg.orientation_window_size)
        return GlobalPlanResult(path=world, goal=goal_xy, length=path_length(world), potential=self.potential,
                                yaws=yaws)

    def _seeds(self, cost, sc, s_xy):
        """Cells (flat) and potentials the expansion starts from: the start cell at 0, or
        (precise start) the four cells around the start point at cost x distance."""
        ny, nx = cost.shape
        if self.config.old_navfn_behavior:
            return np.array([sc[1] * nx + sc[0]], np.int64), np.zeros(1)
        x0, y0 = int(math.floor(s_xy[0])), int(math.floor(s_xy[1]))
        cells, pots = [], []
        for y in (y0, y0 + 1):
            for x in (x0, x0 + 1):  # the start cell is one of them, and passable
                if 0 <= x < nx and 0 <= y < ny and np.isfinite(cost[y, x]):
                    cells.append(y * nx + x)
                    pots.append(float(cost[y, x]) * math.hypot(x - s_xy[0], y - s_xy[1]))
        return np.array(cells, np.int64), np.array(pots)

    def _path(self, pot, s_xy, g_xy, sc, target):
        """Cells (M, 2) [continuous, centres at integers] from the goal point to the start, or None."""
        ny, nx = pot.shape
        flat = pot.ravel()
        max_cycles = 4 * nx * ny
        if not self.config.use_grid_path:
            cells, ok = gradient_path(flat, nx, ny, float(s_xy[0]), float(s_xy[1]), float(g_xy[0]),
                                      float(g_xy[1]), PATH_STEP, max_cycles)
            if ok:
                return cells
        cells, ok = grid_path(flat, nx, ny, int(sc[0]), int(sc[1]), int(target[0]), int(target[1]), max_cycles)
        return cells if ok else None


def _open_start_region(data, cost, sc, value):
    """navfn.start_region made passable at value (in place)."""
    cost[start_region(~np.isfinite(cost), data == LETHAL_OBSTACLE, sc)] = value
