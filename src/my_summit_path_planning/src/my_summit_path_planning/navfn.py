"""NavFn global planner: Dijkstra navigation function + gradient-descent path.

Reference: ROS 1 navigation ``navfn`` (navfn.h / navfn.cpp, navfn_ros.cpp), after
Brock & Khatib 1999 / Konolige 2000 "A Gradient Method for Realtime Robot Control"
(the navigation function); wiki.ros.org/navfn for the parameters.

The algorithm, in the order it runs:
1. Cell costs: ``COST_NEUTRAL + COST_FACTOR * costmap cost`` for costs below
   INSCRIBED (253); inscribed and lethal cells are forbidden; unknown cells (255) cost
   COST_OBS - 1 when allow_unknown, else are forbidden (navfn's setCostmap).
2. Potential: Dijkstra from the robot's cell over the grid (navfn_ros seeds the
   propagation at the robot so that default_tolerance can pick any reached cell near
   the goal). We run a compiled Dijkstra (C, built ahead of time:
   summit_nav_common.native, csrc/grid_graph.c) on an 8-connected grid graph, its CSR
   matrix written in one compiled pass over the cells (``grid_graph_matrix_reference``
   builds it through SciPy's COO, the test oracle), edge weight = mean of the two cell costs x step length [cells]. (navfn
   itself propagates a 4-connected wavefront with a quadratic interpolation; the
   8-connected graph gives a comparably isotropic potential, and the slow pure-Python
   ``dijkstra_reference`` on the same graph is the test oracle.)
   Bounded like A*: only the cells a path to the goal can need are settled
   (GridGraph.potential_toward: edge weights reduced by a consistent octile heuristic,
   lifted by a coarse-grid cost-to-goal guide, and a distance limit from a coarse-grid
   cost estimate; the full search runs when the goal is blocked, for default_tolerance).
3. Goal: the goal cell if it was reached; else, with default_tolerance > 0, the reached
   cell closest to the goal inside the tolerance square (navfn_ros::makePlan).
4. Path: from the goal down the potential's gradient to the robot (navfn's calcPath):
   steps of PATH_STEP cells along the bilinearly interpolated, per-cell normalized
   gradient; where any neighbour of the current cell is unreached (an obstacle) or the
   path oscillates, a grid step to the lowest-potential neighbour instead. Either way
   each point lies in a reached cell, so the path never touches a forbidden cell.
5. Straightening (shortcut_path): the 8-connected potential makes the descent follow
   octile directions; a straight segment replaces a stretch of path when it stays in
   cells whose neighbours are all passable and costs no more in navfn's metric (cell
   cost integrated along it), then the path is resampled every PATH_STEP.

Deliberate difference from navfn: a robot whose centre is in an inscribed (or, without
allow_unknown, unknown) cell still gets a plan: the forbidden, non-lethal cells near
the start and no deeper in that region than the start (start_region) are made passable
at the highest cost (COST_OBS - 1), so the plan leads out by a short way (the real
navfn returns no plan there and the robot needs a recovery). Not the whole region: the
inscribed bands along walls join up round corners and through gaps between wall cells,
and opened whole they let the plan cut through a wall. A start in a lethal cell still
fails.
"""
import heapq
import math
from dataclasses import dataclass

import numpy as np

from .cost_values import INSCRIBED_INFLATED_OBSTACLE, LETHAL_OBSTACLE, NO_INFORMATION
from summit_nav_common.grid_kernels import components8, dilate3, erode3, upsample_linear

from .global_plan import (NEIGHBOURS, POT_HIGH, PlanResult, _nearest_reached, _why_unreachable, path_length,
                          plan_endpoints, start_region)
from summit_nav_common.native import library as _native

# navfn.h: navfn cost values are COST_NEUTRAL + COST_FACTOR * costmap cost. Costmap
# costs 0..252 then spread evenly over 50..251. With a larger factor the costs near
# obstacles would saturate at COST_OBS - 1 into a plateau, and the planner would see a
# whole narrow hallway as equally bad and stop planning down its centre; with a
# smaller neutral cost, obstacle cost would dominate path length.
COST_NEUTRAL = 50      # cost of a free cell [navfn cost units per cell]
COST_FACTOR = 0.8      # navfn cost units per costmap cost unit
COST_OBS = 254         # navfn's forbidden-cell value
PATH_STEP = 0.5        # gradient-descent step [cells] (navfn's pathStep)
SQRT2 = math.sqrt(2.0)
# A* bounding (GridGraph.potential_toward): the search from the robot runs SciPy's Dijkstra
# on edge weights reduced by an octile-distance heuristic to the goal, with a distance
# limit, so it settles only the cells that can lie on a path at most that expensive.
COARSE_FACTOR = 4      # [cells] block size of the coarse grid that estimates the plan cost
BOUND_MARGIN = 1.04    # limit = this x the coarse cost estimate (which runs ~2-4 % low)
BOUND_GROWTH = 1.15    # the limit grows by this factor when the goal was not settled
GUIDE_WEIGHT = 0.9     # coarse cost-to-goal x this = the A* guide (kept below the true cost)
BOUND_TRIES = 3        # limited tries before the full (unlimited) Dijkstra
# Path shortcutting (shortcut_path): candidate ends looked at ahead of each anchor.
SHORTCUT_STRIDE = 8    # [path points] between candidate ends
SHORTCUT_WINDOW = 320  # [path points] (PATH_STEP each) looked ahead at most
SHORTCUT_SAMPLE = 1.0   # [cells] sample spacing along a segment (safe cells: 3x3-eroded)
# 8-connected neighbour offsets (dx, dy) and step lengths [cells].


@dataclass
class NavfnConfig:
    """navfn's ROS parameters (NavfnROS namespace)."""

    allow_unknown: bool = True            # plan through unknown cells
    default_tolerance: float = 0.0        # [m] accept a reachable goal this close to the goal
    planner_window_x: float = 0.0         # [m] accepted for compatibility; 0 = whole costmap
    planner_window_y: float = 0.0         # [m]
    visualize_potential: bool = False     # keep the potential for publishing


def navfn_costs(costs, allow_unknown):
    """Costmap costs (H, W) uint8 -> navfn cell costs (H, W) float64, inf = forbidden."""
    c = np.asarray(costs)
    out = np.floor(COST_NEUTRAL + COST_FACTOR * c.astype(np.float64))
    out = np.minimum(out, COST_OBS - 1)
    out[c >= INSCRIBED_INFLATED_OBSTACLE] = np.inf
    if allow_unknown:
        out[c == NO_INFORMATION] = COST_OBS - 1
    return out


class CSRGraph:
    """A directed graph in compressed sparse rows, as SciPy's csr_matrix holds it:
    row u's edges are indices[indptr[u]:indptr[u + 1]] (int32 targets) with weights
    data[...] (float64). Only what the compiled kernels read; no SciPy in the node."""

    def __init__(self, data, indices, indptr, n):
        self.data, self.indices, self.indptr, self.shape = data, indices, indptr, (n, n)

    @property
    def nnz(self):
        return int(self.indptr[-1])


def _grid_csr(cost, passable, node_of):
    """(indptr, indices, data) of GridGraph's CSR matrix in one compiled pass over the
    cells: each passable cell's row lists its passable 8-neighbours in increasing node
    index, the edge weighing the mean of the two cell costs x the step length [cells]."""
    cost = np.ascontiguousarray(cost, dtype=np.float64)
    ok = np.ascontiguousarray(passable, dtype=np.uint8)
    h, w = cost.shape
    n = int(np.count_nonzero(ok))
    indptr = np.zeros(n + 1, dtype=np.int64)
    indices = np.empty(8 * n, dtype=np.int32)
    data = np.empty(8 * n)
    k = _native().snc_grid_csr(cost, ok, np.ascontiguousarray(node_of, dtype=np.int64), h, w,
                                indptr, indices, data)
    return indptr, indices[:k], data[:k]


def _reduced_weights(indptr, indices, data, heur):
    """A*'s reduced edge weights w + h(v) - h(u) of a CSR matrix in one compiled pass over
    its rows, clipped at 0 (rounding only: the heuristic is consistent)."""
    indptr = np.ascontiguousarray(indptr, dtype=np.int64)
    out = np.empty(len(data))
    _native().snc_reduced_weights(indptr, np.ascontiguousarray(indices, dtype=np.int32),
                                  np.ascontiguousarray(data, dtype=np.float64),
                                  np.ascontiguousarray(heur, dtype=np.float64), indptr.size - 1, out)
    return out


def _dijkstra(graph, source, limit=np.inf):
    """Distances (n,) from node `source` over a CSRGraph, +inf where farther than `limit`
    (scipy.sparse.csgraph.dijkstra(graph, directed=True, indices=source, limit=limit))."""
    n = graph.shape[0]
    dist = np.empty(n)
    if _native().snc_dijkstra(graph.indptr, graph.indices, graph.data, n, int(source), float(limit), dist):
        raise MemoryError("navfn: no memory for Dijkstra's heap")
    return dist


def reduced_weights_reference(matrix, heur):
    """_reduced_weights with NumPy: the targets' h gathered, the sources' h repeated over
    each row (the test oracle)."""
    reduced = np.take(heur, matrix.indices) - np.repeat(heur, np.diff(matrix.indptr)) + matrix.data
    return np.maximum(reduced, 0.0)


def grid_graph_matrix_reference(cell_cost):
    """GridGraph's CSR matrix built edge list by edge list through SciPy's COO (test oracle)."""
    import scipy.sparse as sp   # the oracle's only; the planner itself needs no SciPy
    cost = np.asarray(cell_cost, dtype=np.float64)
    h, w = cost.shape
    passable = np.isfinite(cost)
    cells = np.flatnonzero(passable.ravel())
    node_of = np.full(h * w, -1, dtype=np.int64)
    node_of[cells] = np.arange(cells.size)
    rows, cols, wts = [], [], []
    flat_cost = cost.ravel()
    # Each undirected edge once (right, up, up-right, up-left), then both directions.
    for dx, dy in ((1, 0), (0, 1), (1, 1), (-1, 1)):
        ys0, ys1 = 0, h - dy
        xs0, xs1 = max(0, -dx), w - max(0, dx)
        a = passable[ys0:ys1, xs0:xs1] & passable[ys0 + dy:ys1 + dy, xs0 + dx:xs1 + dx]
        yy, xx = np.nonzero(a)
        ia = (yy + ys0) * w + (xx + xs0)
        ib = ia + dy * w + dx
        length = SQRT2 if (dx and dy) else 1.0
        wt = 0.5 * (flat_cost[ia] + flat_cost[ib]) * length
        na, nb = node_of[ia], node_of[ib]
        rows += [na, nb]
        cols += [nb, na]
        wts += [wt, wt]
    n = cells.size
    return sp.csr_matrix((np.concatenate(wts), (np.concatenate(rows), np.concatenate(cols))), shape=(n, n))


class GridGraph:
    """The 8-connected graph of the passable cells of a cost grid.

    cell_cost: (H, W) float, inf for forbidden cells. node_of: (H*W,) node index or -1;
    cells: (n,) flat cell index of each node. The searches run on the grid itself
    (csrc/grid_graph.c's snc_grid_dijkstra: the weights computed where they are used);
    ``matrix``, the same graph as a CSR matrix (CSRGraph), is built only when asked for
    (the tests compare it with SciPy's), not by the planner: for a 440 x 320 map it and
    A*'s reduced copy took ~16 MB a plan.
    """

    def __init__(self, cell_cost):
        self.cost = np.ascontiguousarray(cell_cost, dtype=np.float64)
        self.shape = self.cost.shape
        finite = np.isfinite(self.cost)
        self.min_cost = float(np.min(self.cost, where=finite, initial=np.inf)) if finite.any() else COST_NEUTRAL
        self._cells = self._node_of = None   # built only for `matrix` (2 int64 per cell: issue 43)
        self._matrix = None

    @property
    def cells(self):
        if self._cells is None:
            self._cells = np.flatnonzero(np.isfinite(self.cost).ravel())
        return self._cells

    @property
    def node_of(self):
        if self._node_of is None:
            self._node_of = np.full(self.shape[0] * self.shape[1], -1, dtype=np.int64)
            self._node_of[self.cells] = np.arange(self.cells.size)
        return self._node_of

    def passable(self, cell):
        """Whether flat cell index `cell` is a node of the graph."""
        return math.isfinite(self.cost.flat[cell])

    @property
    def matrix(self):
        """The graph as a CSRGraph: each passable cell's row lists its passable neighbours
        in increasing node index, weight = mean cell cost x step length."""
        if self._matrix is None:
            indptr, indices, data = _grid_csr(self.cost, np.isfinite(self.cost), self.node_of)
            self._matrix = CSRGraph(data, indices, indptr, self.cells.size)
        return self._matrix

    def _search(self, source_cell, heur, limit):
        """Distances (H*W,) from source_cell over the grid, A*-reduced by heur (H*W,) or
        not (None), +inf where not reached within limit."""
        dist = np.empty(self.shape[0] * self.shape[1])
        ptr = None if heur is None else heur.ctypes.data
        if _native().snc_grid_dijkstra(self.cost, ptr, self.shape[0], self.shape[1], int(source_cell),
                                       float(limit), dist):
            raise MemoryError("navfn: no memory for Dijkstra's heap")
        return dist

    def component_of(self, cell):
        """8-connected component label of flat cell index cell (-1 if not passable)."""
        if getattr(self, "_labels", None) is None:
            # the components of the graph are those of the passable cells, 8-connected
            self._labels = components8(np.isfinite(self.cost).astype(np.uint8)).ravel()
        return int(self._labels[cell]) if self.passable(cell) else -1

    def potential_toward(self, source_cell, target_cell, cost_estimate=None, guide=None):
        """Dijkstra potential from source_cell, settled only as far as target_cell needs.

        A* through the compiled Dijkstra: edge weights are reduced by the consistent heuristic
        h = (cheapest cell cost) x octile distance to the target, w' = w + h(v) - h(u) >= 0,
        and Dijkstra on w' with a distance limit settles exactly the cells v with
        d(s, v) + h(v) <= limit + h(s); their potentials d(s, v) are exact. The limit
        starts at BOUND_MARGIN x cost_estimate (a plan cost estimate, e.g. from a coarse
        grid) and grows until the target is settled; when it cannot be (different
        components), or after BOUND_TRIES, the full Dijkstra runs.
        Returns (H, W) potentials, POT_HIGH where not settled.
        """
        if not self.passable(source_cell) or not self.passable(target_cell) \
                or self.component_of(source_cell) != self.component_of(target_cell):
            return self.potential(source_cell)
        h, w = self.shape
        tx, ty = target_cell % w, target_cell // w
        dx = np.abs(np.arange(w) - tx).astype(np.float64)[None, :]
        dy = np.abs(np.arange(h) - ty).astype(np.float64)[:, None]
        # in place: each full-grid temporary is 8 bytes a cell (issue 43); same values
        heur = np.maximum(dx, dy)
        heur += (SQRT2 - 1.0) * np.minimum(dx, dy)
        heur *= self.min_cost
        heur = heur.ravel()
        if guide is not None:
            np.maximum(heur, np.asarray(guide).ravel(), out=heur)
        hs = heur[source_cell]
        est = hs if cost_estimate is None or not math.isfinite(cost_estimate) else max(hs, cost_estimate)
        limit = max(BOUND_MARGIN * est - hs, self.min_cost)
        for _ in range(BOUND_TRIES):
            d = self._search(source_cell, heur, limit)     # on w' = w + h(v) - h(u)
            if np.isfinite(d[target_cell]):
                reached = np.isfinite(d)
                d += hs            # d(s, v) = d'(s, v) + h(s) - h(v), in place
                d -= heur
                d[~reached] = POT_HIGH
                d[source_cell] = 0.0
                return d.reshape(self.shape)
            limit = BOUND_GROWTH * (limit + hs) - hs
        return self.potential(source_cell)

    def potential(self, source_cell, limit=np.inf):
        """Dijkstra distances (H, W) from flat cell index source_cell; POT_HIGH where unreached."""
        pot = np.full(self.shape[0] * self.shape[1], POT_HIGH)
        if not self.passable(source_cell):
            return pot.reshape(self.shape)
        d = self._search(source_cell, None, limit)
        reached = np.isfinite(d)
        pot[reached] = d[reached]
        return pot.reshape(self.shape)


def dijkstra_reference(cell_cost, source):
    """Slow, obvious Dijkstra on the same 8-connected graph (the test oracle).

    cell_cost: (H, W) float, inf forbidden; source: (x, y) cell. Returns (H, W)
    potentials, POT_HIGH where unreached.
    """
    h, w = len(cell_cost), len(cell_cost[0])
    pot = [[POT_HIGH] * w for _ in range(h)]
    sx, sy = source
    if not math.isfinite(cell_cost[sy][sx]):
        return np.array(pot)
    pot[sy][sx] = 0.0
    heap = [(0.0, sx, sy)]
    done = set()
    while heap:
        p, x, y = heapq.heappop(heap)
        if (x, y) in done:
            continue
        done.add((x, y))
        for dx, dy in NEIGHBOURS:
            nx, ny = x + dx, y + dy
            if 0 <= nx < w and 0 <= ny < h and math.isfinite(cell_cost[ny][nx]):
                step = SQRT2 if (dx and dy) else 1.0
                q = p + 0.5 * (cell_cost[y][x] + cell_cost[ny][nx]) * step
                if q < pot[ny][nx]:
                    pot[ny][nx] = q
                    heapq.heappush(heap, (q, nx, ny))
    return np.array(pot)


def potential_gradient(pot):
    """navfn's gradCell for every cell: unit downhill gradient (gx, gy) (H, W) each.

    Central differences over the reachable neighbours only; zero where no neighbour is
    reachable. (gradient_path computes the same per cell, lazily, along the path.)
    """
    p = np.asarray(pot, dtype=np.float64)
    ok = p < POT_HIGH
    pad = np.pad(p, 1, constant_values=POT_HIGH)
    okp = pad < POT_HIGH
    left, right = pad[1:-1, :-2], pad[1:-1, 2:]
    down, up = pad[:-2, 1:-1], pad[2:, 1:-1]
    gx = np.where(okp[1:-1, :-2], left - p, 0.0) + np.where(okp[1:-1, 2:], p - right, 0.0)
    gy = np.where(okp[:-2, 1:-1], down - p, 0.0) + np.where(okp[2:, 1:-1], p - up, 0.0)
    gx[~ok] = 0.0
    gy[~ok] = 0.0
    norm = np.hypot(gx, gy)
    nz = norm > 0
    gx[nz] /= norm[nz]
    gy[nz] /= norm[nz]
    return gx, gy


def _grad_cell(flat, w, c, cache):
    """Unit downhill gradient of reached, non-border cell c (flat index), memoized."""
    g = cache.get(c)
    if g is None:
        p = flat[c]
        left, right, down, up = flat[c - 1], flat[c + 1], flat[c - w], flat[c + w]
        gx = (left - p if left < POT_HIGH else 0.0) + (p - right if right < POT_HIGH else 0.0)
        gy = (down - p if down < POT_HIGH else 0.0) + (p - up if up < POT_HIGH else 0.0)
        n = math.hypot(gx, gy)
        g = (gx / n, gy / n) if n > 0 else (0.0, 0.0)
        cache[c] = g
    return g


def gradient_path(pot, start_cell, max_cycles=None):
    """navfn's calcPath: descend the potential from start_cell to the source (potential 0).

    pot: (H, W) potentials (POT_HIGH unreached); start_cell: (x, y). Returns (N, 2)
    continuous cell coordinates (cell centres at integers) or None when the descent
    fails (unreached start, zero gradient, too many cycles).
    """
    pot = np.asarray(pot, dtype=np.float64)
    h, w = pot.shape
    sx, sy = start_cell
    if pot[sy, sx] >= POT_HIGH:
        return None
    unreached = (pot >= POT_HIGH).astype(np.uint8)
    # near[c]: some 8-neighbour of c is unreached (or off the grid): take grid steps there.
    near = dilate3(np.pad(unreached, 1, constant_values=1))[1:-1, 1:-1]
    near = near.ravel()
    flat = pot.ravel()
    cache = {}
    if max_cycles is None:
        max_cycles = 4 * (h + w) + h * w // 50
    px, py = float(sx), float(sy)
    path = [(px, py)]
    for _ in range(max_cycles):
        cx, cy = int(math.floor(px + 0.5)), int(math.floor(py + 0.5))
        c = cy * w + cx
        if flat[c] < COST_NEUTRAL:  # in the source cell
            path.append((float(cx), float(cy)))
            return np.array(path)
        oscillating = len(path) > 2 and path[-1] == path[-3]
        if near[c] or oscillating:
            best, bx, by = flat[c], cx, cy
            for dx, dy in NEIGHBOURS:
                nx, ny = cx + dx, cy + dy
                if 0 <= nx < w and 0 <= ny < h and flat[ny * w + nx] < best:
                    best, bx, by = flat[ny * w + nx], nx, ny
            if (bx, by) == (cx, cy):
                return None  # local minimum: cannot happen on a Dijkstra potential
            px, py = float(bx), float(by)
        else:
            # Bilinear interpolation of the four cells around the point; all reached,
            # because they are neighbours of c, which is not near an unreached cell.
            ix, iy = int(math.floor(px)), int(math.floor(py))
            fx, fy = px - ix, py - iy
            i00 = iy * w + ix
            g00 = _grad_cell(flat, w, i00, cache)
            g10 = _grad_cell(flat, w, i00 + 1, cache)
            g01 = _grad_cell(flat, w, i00 + w, cache)
            g11 = _grad_cell(flat, w, i00 + w + 1, cache)
            vx = (1 - fy) * ((1 - fx) * g00[0] + fx * g10[0]) + fy * ((1 - fx) * g01[0] + fx * g11[0])
            vy = (1 - fy) * ((1 - fx) * g00[1] + fx * g10[1]) + fy * ((1 - fx) * g01[1] + fx * g11[1])
            norm = math.hypot(vx, vy)
            if norm == 0.0:
                return None
            px += PATH_STEP * vx / norm
            py += PATH_STEP * vy / norm
        path.append((px, py))
    return None


def coarse_cost_grid(cell_cost, factor=COARSE_FACTOR):
    """Optimistic coarse version of a cell-cost grid: each factor x factor block gets its
    cheapest cell's cost (inf when all its cells are forbidden). Distances on it x factor
    estimate (mostly from below) the plan cost on the fine grid."""
    c = np.asarray(cell_cost, dtype=np.float64)
    h, w = c.shape
    hp, wp = -(-h // factor) * factor, -(-w // factor) * factor
    pad = np.full((hp, wp), np.inf)
    pad[:h, :w] = c
    return pad.reshape(hp // factor, factor, wp // factor, factor).min(axis=(1, 3))


def shortcut_path(cells, cell_cost, safe=None):
    """Straighten a descent path where a straight segment is cheaper in navfn's metric.

    cells: (N, 2) continuous cell coordinates (centres at integers); cell_cost: (H, W)
    navfn costs (inf forbidden); safe: (H, W) bool, cells a straight segment may cross
    (default: passable cells whose 8 neighbours are passable too, so that a segment
    between two samples SHORTCUT_SAMPLE apart cannot clip a forbidden cell).
    Greedy string pulling: from each anchor, the farthest candidate point whose straight
    segment stays in safe cells and whose cost integral (sum of sampled cell costs x
    length) is at most that of the path it replaces. The 8-connected potential makes
    the descent follow octile directions (up to 8 % longer than straight); this removes
    that without pulling the path into the inflated cost near walls.
    Returns (M, 2) with the same ends.
    """
    p = np.asarray(cells, dtype=np.float64)
    if len(p) < 3:
        return p
    cost = np.asarray(cell_cost, dtype=np.float64)
    h, w = cost.shape
    if safe is None:
        ok = np.isfinite(cost).astype(np.uint8)
        safe = erode3(np.pad(ok, 1, constant_values=0))[1:-1, 1:-1] > 0

    def cell_cost_at(q):
        ix = np.clip(np.floor(q[:, 0] + 0.5).astype(np.int64), 0, w - 1)
        iy = np.clip(np.floor(q[:, 1] + 0.5).astype(np.int64), 0, h - 1)
        return cost[iy, ix], safe[iy, ix]

    # Cost integral of the path up to each point (same sampling rule as the segments).
    seg_len = np.hypot(*np.diff(p, axis=0).T)
    mid = 0.5 * (p[:-1] + p[1:])
    c_end, _ = cell_cost_at(p)
    c_mid, _ = cell_cost_at(mid)
    # (A diagonal grid step past a corner has its midpoint in a forbidden cell: count it
    # at COST_OBS so the integral stays finite.)
    c_end, c_mid = np.minimum(c_end, COST_OBS), np.minimum(c_mid, COST_OBS)
    seg_cost = seg_len * (0.25 * c_end[:-1] + 0.5 * c_mid + 0.25 * c_end[1:])
    prefix = np.concatenate([[0.0], np.cumsum(seg_cost)])
    out = [p[0]]
    i, n = 0, len(p)
    while i < n - 1:
        cand = np.arange(min(n - 1, i + SHORTCUT_WINDOW), i + 1, -SHORTCUT_STRIDE)
        best = i + 1
        if len(cand):
            # All candidate segments' samples at once: segment k has m[k] samples.
            seg = p[cand] - p[i]
            length = np.hypot(seg[:, 0], seg[:, 1])
            m = np.maximum(2, np.ceil(length / SHORTCUT_SAMPLE).astype(np.int64) + 1)
            own = np.repeat(np.arange(len(cand)), m)
            first = np.concatenate([[0], np.cumsum(m)[:-1]])
            pos = np.arange(own.size) - first[own]
            t = pos / (m[own] - 1.0)
            c, sf = cell_cost_at(p[i] + t[:, None] * seg[own])
            # Trapezoid rule per segment: its two ends weigh half.
            wgt = np.where((pos == 0) | (pos == m[own] - 1), 0.5, 1.0)
            line_cost = np.bincount(own, weights=np.where(sf, c, 0.0) * wgt, minlength=len(cand)) \
                * length / (m - 1)
            line_ok = np.bincount(own, weights=(~sf).astype(np.float64), minlength=len(cand)) == 0
            good = line_ok & (line_cost <= prefix[cand] - prefix[i] + 1e-9)
            if good.any():
                best = int(cand[np.argmax(good)])  # cand runs from far to near
        out.append(p[best])
        i = best
    return np.array(out)


def resample_path(path, step):
    """Points every <= step along a polyline (N, 2), its vertices' ends kept."""
    p = np.asarray(path, dtype=np.float64)
    if len(p) < 2:
        return p
    seg = np.hypot(*np.diff(p, axis=0).T)
    arc = np.concatenate([[0.0], np.cumsum(seg)])
    n = max(2, int(math.ceil(arc[-1] / step)) + 1)
    s = np.linspace(0.0, arc[-1], n)
    return np.column_stack([np.interp(s, arc, p[:, 0]), np.interp(s, arc, p[:, 1])])


def grid_descent_path(pot, start_cell):
    """Steepest-descent path over 8-neighbours (cell centres) from start_cell to the source."""
    pot = np.asarray(pot)
    h, w = pot.shape
    x, y = start_cell
    path = [(x, y)]
    while pot[y, x] > 0:
        best, bx, by = pot[y, x], x, y
        for dx, dy in NEIGHBOURS:
            nx, ny = x + dx, y + dy
            if 0 <= nx < w and 0 <= ny < h and pot[ny, nx] < best:
                best, bx, by = pot[ny, nx], nx, ny
        if (bx, by) == (x, y):
            return None
        x, y = bx, by
        path.append((x, y))
    return np.array(path, dtype=np.float64)


def grid_geodesic_length(passable, start_cell, goal_cell):
    """Exact shortest 8-connected path length [cells] between two cells of a bool grid.

    The benchmark's reference: unit cost per cell step (sqrt 2 diagonally); inf when
    unreachable.
    """
    cost = np.where(np.asarray(passable, dtype=bool), 1.0, np.inf)
    g = GridGraph(cost)
    h, w = cost.shape
    pot = g.potential(start_cell[1] * w + start_cell[0])
    v = pot[goal_cell[1], goal_cell[0]]
    return float(v) if v < POT_HIGH else math.inf


class NavFn:
    """The NavFn global planner (base_global_planner's makePlan, without ROS).

    config: a NavfnConfig. The grid graph is cached between plans while the costmap's
    costs do not change.
    """

    def __init__(self, config=None):
        self.config = config or NavfnConfig()
        self._cache_key = None
        self._cache_data = None        # the costmap costs the cached cell costs are of
        self._cache_cell_cost = None
        self._graph = None

    def _graph_for(self, cell_cost):
        # the graph holds the cell costs it was built on (never written after): no copy
        built_on = None if self._graph is None else self._graph.cost
        if built_on is not None and (built_on is cell_cost or (built_on.shape == cell_cost.shape
                                                              and np.array_equal(built_on, cell_cost))):
            return self._graph
        self._graph = GridGraph(cell_cost)
        self._coarse = GridGraph(coarse_cost_grid(cell_cost))
        ok = np.isfinite(cell_cost).astype(np.uint8)
        self._safe = erode3(np.pad(ok, 1, constant_values=0))[1:-1, 1:-1] > 0
        return self._graph

    def _coarse_guide(self, sc, gc, shape):
        """(plan cost estimate [navfn units] from cell sc to cell gc, or None;
        (H, W) A* guide: GUIDE_WEIGHT x the coarse cost-to-goal, bilinear between block centres).
        """
        k = COARSE_FACTOR
        cw = self._coarse.shape[1]
        pot = self._coarse.potential(gc[1] // k * cw + gc[0] // k)
        v = pot[sc[1] // k, sc[0] // k]
        if v >= POT_HIGH:
            return None, None
        reached = pot < POT_HIGH
        pot = np.where(reached, pot * k, 0.0).astype(np.float32)
        # Blocks with no passable cell take their neighbours' largest value, so the
        # interpolation does not dip next to walls.
        grown = dilate3(pot)
        pot = np.where(reached, pot, grown)
        h, w = shape
        fine = upsample_linear(pot, k)
        return k * float(v), GUIDE_WEIGHT * fine[:h, :w]

    def make_plan(self, costmap, start, goal, tolerance=None):
        """Plan on costmap (a Costmap2D) from start (x, y) [m] to goal (x, y) [m].

        tolerance [m]: overrides default_tolerance. Returns a PlanResult; its reason says
        why there is no plan (bad or off-map input, start in a lethal cell, goal in an
        obstacle / unknown space / unreachable).
        """
        cfg = self.config
        tol = cfg.default_tolerance if tolerance is None else float(tolerance)
        sc, gc, why = plan_endpoints(costmap, start, goal)
        if why:
            return PlanResult(reason=why)
        data = costmap.data
        # navfn's cell costs, recomputed only when the costmap changed (replanning at
        # planner_frequency on an unchanged costmap reuses them and the graph).
        if self._cache_data is not None and self._cache_data.shape == data.shape \
                and np.array_equal(self._cache_data, data):
            cell_cost = self._cache_cell_cost
        else:
            cell_cost = navfn_costs(data, cfg.allow_unknown)
            self._cache_data, self._cache_cell_cost = data.copy(), cell_cost
        if not np.isfinite(cell_cost[sc[1], sc[0]]):
            cell_cost = _open_start_region(data, cell_cost, sc)
        h, w = data.shape
        graph = self._graph_for(cell_cost)
        if np.isfinite(cell_cost[gc[1], gc[0]]):
            # Settle only what a path to the goal needs (A*-bounded, exact potentials).
            estimate, guide = self._coarse_guide(sc, gc, data.shape)
            pot = graph.potential_toward(sc[1] * w + sc[0], gc[1] * w + gc[0], estimate, guide)
        else:
            pot = graph.potential(sc[1] * w + sc[0])  # default_tolerance looks around the goal
        target = gc
        if pot[gc[1], gc[0]] >= POT_HIGH:
            target = _nearest_reached(pot, costmap, goal, tol) if tol > 0 else None
            if target is None:
                return PlanResult(reason=_why_unreachable(data[gc[1], gc[0]], cfg.allow_unknown, tol, pot,
                                                          costmap.resolution),
                                  potential=pot if cfg.visualize_potential else None)
        cells = gradient_path(pot, target)
        if cells is None or not _all_reached(pot, cells):
            cells = grid_descent_path(pot, target)  # always succeeds on a Dijkstra potential
        if cells is None:
            return PlanResult(reason="no path: the gradient descent failed")
        cells = resample_path(shortcut_path(cells, cell_cost, self._safe), PATH_STEP)
        res = costmap.resolution
        world = np.column_stack([costmap.origin_x + (cells[:, 0] + 0.5) * res,
                                 costmap.origin_y + (cells[:, 1] + 0.5) * res])[::-1]
        goal_xy = (float(goal[0]), float(goal[1])) if target == gc else \
            costmap.map_to_world(*target)
        world[0] = (float(start[0]), float(start[1]))
        world[-1] = goal_xy
        return PlanResult(path=world, goal=goal_xy, length=path_length(world),
                          potential=pot if cfg.visualize_potential else None)


def _all_reached(pot, cells):
    idx = np.floor(cells + 0.5).astype(np.int64)
    return bool((pot[idx[:, 1], idx[:, 0]] < POT_HIGH).all())


def _open_start_region(data, cell_cost, sc):
    """cell_cost with start_region passable at COST_OBS - 1."""
    out = cell_cost.copy()
    out[start_region(~np.isfinite(cell_cost), data == LETHAL_OBSTACLE, sc)] = COST_OBS - 1
    return out


