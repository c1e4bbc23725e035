"""base_local_planner's footprint cost (CostmapModel::footprintCost): the footprint's
outline, its edges rasterized with Bresenham's line, against the costmap.

Used by TrajectoryPlannerROS (every trajectory point) and carrot_planner (the legal pose
nearest the goal). ``footprint_costs`` checks many poses at once (``outline_costs``, C:
summit_nav_common/csrc/footprint_cost.c, built by catkin, called through ctypes: the
outline's cells, stopping at the first lethal or unknown one); the kernel's Python twin
``_outline_costs`` is the C's bit-for-bit oracle and ``footprint_cost_reference`` the slow,
obvious oracle of both.
"""
import math

import numpy as np

from .cost_values import LETHAL_OBSTACLE, NO_INFORMATION
from summit_nav_common.native import library
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


def _outline_costs(data, vx, vy, on_map):
    """(M,) _outline_cost of each pose's vertex cells (M, K); OFF_MAP where not on_map."""
    out = np.empty(vx.shape[0])
    for m in range(vx.shape[0]):
        out[m] = _outline_cost(data, vx[m], vy[m]) if on_map[m] else OFF_MAP
    return out


def check_vertex_cells(what, data, vx, vy):
    """vx, vy as C-contiguous int64 arrays of one shape, every cell on the (H, W) grid data
    (the compiled kernels read the grid there); ValueError naming `what` otherwise."""
    vx, vy = np.ascontiguousarray(vx, dtype=np.int64), np.ascontiguousarray(vy, dtype=np.int64)
    h, w = data.shape
    if vx.shape != vy.shape:
        raise ValueError(f"{what}: vertex cells of shapes {vx.shape} and {vy.shape}")
    if vx.size and (vx.min() < 0 or vy.min() < 0 or vx.max() >= w or vy.max() >= h):
        raise ValueError(f"{what}: a vertex cell off the {w} x {h} costmap")
    return vx, vy


def outline_costs(data, vx, vy, on_map):
    """_outline_costs in C: (M,) outline cost of each pose's vertex cells vx, vy (M, K)
    on the uint8 grid data (H, W); OFF_MAP where not on_map (M,) bool."""
    data = np.ascontiguousarray(data, dtype=np.uint8)
    vx, vy = check_vertex_cells("outline_costs", data, vx, vy)
    on_map = np.ascontiguousarray(on_map, dtype=bool)
    m, k = vx.shape
    if on_map.shape != (m,):
        raise ValueError(f"outline_costs: on_map of shape {on_map.shape} for {m} poses")
    out = np.empty(m)
    library().snc_outline_costs(data, data.shape[1], vx, vy, on_map.view(np.uint8), m, k, out)
    return out


def footprint_costs(costmap, polygon, x, y, th):
    """CostmapModel::footprintCost for many poses at once.

    polygon (K, 2) [m] robot frame; x, y, th (M,). Returns (M,) costs: OFF_MAP when the
    centre or a vertex is off the costmap, COLLIDES when a cell of the outline (edges
    rasterized with Bresenham, closing edge included) is lethal or unknown, else the
    highest cost on the outline.
    """
    vx, vy, on_map = _vertex_cells(costmap, polygon, x, y, th)
    return outline_costs(costmap.data, vx, vy, on_map)


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
