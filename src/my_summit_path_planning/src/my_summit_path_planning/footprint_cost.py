"""base_local_planner's footprint cost (CostmapModel::footprintCost): the footprint's
outline, its edges rasterized with Bresenham's line, against the costmap.

Used by TrajectoryPlannerROS (every trajectory point) and carrot_planner (the legal pose
nearest the goal). ``footprint_costs`` checks many poses at once (compiled with numba:
the outline's cells, stopping at the first lethal or unknown one);
``footprint_cost_reference`` is its slow, obvious oracle.
"""
import math

import numpy as np

from .cost_values import LETHAL_OBSTACLE, NO_INFORMATION
from summit_nav_common.jit import njit
from summit_nav_common.line_cells import line_cells_padded, line_cells_reference

OFF_MAP = -3.0              # footprint cost: a vertex or the centre off the costmap


COLLIDES = -1.0             # trajectory cost: the footprint met a lethal/unknown cell or left the map


# -- geometry on the grid ---------------------------------------------------------------
def world_to_cells(costmap, x, y):
    """(mx, my, inside) of world points [m] (any shape): costmap_2d's worldToMap."""
    mx = np.floor((np.asarray(x) - costmap.origin_x) / costmap.resolution).astype(np.int64)
    my = np.floor((np.asarray(y) - costmap.origin_y) / costmap.resolution).astype(np.int64)
    inside = (mx >= 0) & (my >= 0) & (mx < costmap.size_x) & (my < costmap.size_y)
    return mx, my, inside


# base_local_planner's LineIterator: Bresenham with halves away from zero, as rows
# (xs, ys, valid), and its oracle: summit_nav_common.line_cells.
bresenham = line_cells_padded


def _vertex_cells(costmap, polygon, x, y, th):
    """The footprint's vertex cells at many poses: (vx, vy) (M, K) int and on_map (M,)
    (the centre and every vertex on the costmap; off it, the vertex cells are 0)."""
    x, y, th = (np.asarray(v, dtype=np.float64).ravel() for v in (x, y, th))
    c, s = np.cos(th)[:, None], np.sin(th)[:, None]
    px = x[:, None] + polygon[:, 0] * c - polygon[:, 1] * s      # (M, K)
    py = y[:, None] + polygon[:, 0] * s + polygon[:, 1] * c
    vx, vy, vin = world_to_cells(costmap, px, py)
    _, _, cin = world_to_cells(costmap, x, y)
    on_map = cin & vin.all(axis=1)
    vx[~on_map], vy[~on_map] = 0, 0
    return vx, vy, on_map


@njit(cache=True, nogil=True)
def _outline_cost(data, vx, vy):
    """Highest cost on the closed outline through the vertex cells vx, vy (K,) of the
    (H, W) uint8 grid data, its edges walked with Bresenham's iterator (ends included);
    COLLIDES at the first lethal or unknown cell."""
    k_n = vx.shape[0]
    worst = 0
    for k in range(k_n):
        x0, y0 = vx[k], vy[k]
        x1, y1 = vx[(k + 1) % k_n], vy[(k + 1) % k_n]
        dx, dy = abs(x1 - x0), abs(y1 - y0)
        sx = 1 if x1 >= x0 else -1
        sy = 1 if y1 >= y0 else -1
        xmajor = dx >= dy
        den = dx if xmajor else dy
        numadd = dy if xmajor else dx
        num = den // 2
        x, y = x0, y0
        for _ in range(den + 1):
            cost = int(data[y, x])
            if cost == LETHAL_OBSTACLE or cost == NO_INFORMATION:
                return COLLIDES
            if cost > worst:
                worst = cost
            num += numadd
            if num >= den:
                num -= den
                if xmajor:
                    y += sy
                else:
                    x += sx
            if xmajor:
                x += sx
            else:
                y += sy
    return float(worst)


@njit(cache=True, nogil=True)
def _outline_costs(data, vx, vy, on_map):
    """(M,) _outline_cost of each pose's vertex cells (M, K); OFF_MAP where not on_map."""
    out = np.empty(vx.shape[0])
    for m in range(vx.shape[0]):
        out[m] = _outline_cost(data, vx[m], vy[m]) if on_map[m] else OFF_MAP
    return out


def footprint_costs(costmap, polygon, x, y, th):
    """CostmapModel::footprintCost for many poses at once.

    polygon (K, 2) [m] robot frame; x, y, th (M,). Returns (M,) costs: OFF_MAP when the
    centre or a vertex is off the costmap, COLLIDES when a cell of the outline (edges
    rasterized with Bresenham, closing edge included) is lethal or unknown, else the
    highest cost on the outline.
    """
    vx, vy, on_map = _vertex_cells(costmap, polygon, x, y, th)
    return _outline_costs(costmap.data, vx, vy, on_map)


def footprint_cost_reference(costmap, polygon, x, y, th):
    """One pose's footprintCost, edge by edge and cell by cell (test oracle)."""
    c, s = math.cos(th), math.sin(th)
    if costmap.world_to_map(x, y) is None:
        return OFF_MAP
    cells = []
    for px, py in polygon:
        cell = costmap.world_to_map(x + px * c - py * s, y + px * s + py * c)
        if cell is None:
            return OFF_MAP
        cells.append(cell)
    worst = 0.0
    for k in range(len(cells)):
        (x0, y0), (x1, y1) = cells[k], cells[(k + 1) % len(cells)]
        for cx, cy in line_cells_reference(x0, y0, x1, y1):
            cost = int(costmap.data[cy, cx])
            if cost in (LETHAL_OBSTACLE, NO_INFORMATION):
                return COLLIDES
            worst = max(worst, float(cost))
    return worst
