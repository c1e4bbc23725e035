"""gmapping's scan matcher: hill climbing on a beam-endpoint score, and the beam likelihood.

Reference: Grisetti, Stachniss, Burgard 2007, "Improved Techniques for Grid Mapping with
Rao-Blackwellized Particle Filters", IEEE T-RO 23(1), sec. IV (the scan matcher that
focuses the proposal); GMapping's ScanMatcher::optimize / score / likelihoodAndScore
(scanmatcher/scanmatcher.{h,cpp}).

Score of a pose: for every used beam (0 < r < maxUrange, every (lskip+1)-th), the
endpoint's cell and its +-kernelSize neighbours are searched for occupied cells
(hits/visits > FULLNESS_THRESHOLD); d is the distance from the endpoint to the nearest
such cell's mean hit point (the average of the points where beams ended in it, kept by
the grid), not to its centre: that is what gives gmapping's matcher sub-cell resolution.
Found: the score adds exp(-d^2 / sigma) and the log-likelihood -d^2 / lsigma; not found:
the log-likelihood adds NULL_LIKELIHOOD / lsigma. (gmapping also reads a "free" cell
before each candidate, but computes its offset from a difference vector with world2map,
so it reads an unrelated, mostly unknown, cell and the test passes; here there is none.)

Hill climbing (ScanMatcher::optimize): from the odometry-moved pose try +-lstep in x and
y (world axes) and +-astep in theta, move to the best improving neighbour; when none
improves, halve both steps; stop after `iterations` halvings without improvement.

Speed: the score and the climb are compiled ahead of time (C in
summit_nav_common/csrc/patch_grid.c, called through ctypes: summit_nav_common.native) and
read every particle's cells straight from the grids' shared PatchPool through
per-particle tables of patch slots (MapTables). ctypes releases the GIL during the call:
the node's scan and tf threads go on while the filter thread matches. `score_reference` / `optimize_reference` compute the same with
plain Python over PatchGrid.read_layers: the test oracles.
"""
import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np
from summit_nav_common.native import library as _native

from .grid import (FULLNESS_THRESHOLD, HITS, PATCH_CELLS, PATCH_SHIFT, SUM_X, SUM_Y, VISITS,
                   PatchGrid)

NULL_LIKELIHOOD = -0.5         # gmapping's nullLikelihood: log-lik of a beam with no match [-], / lsigma
MAX_CLIMB_STEPS = 500          # safety cap on hill-climbing rounds (gmapping has none) [-]
# The six hill-climbing moves in gmapping's order: front, back, left, right, turn left, turn right.
MOVES = np.array([[1, 0, 0], [-1, 0, 0], [0, -1, 0], [0, 1, 0], [0, 0, 1], [0, 0, -1]], float)


@dataclass
class Beams:
    """The beams a scan contributes to matching: ranges (K,) [m], angles (K,) [rad]."""
    ranges: np.ndarray
    angles: np.ndarray

    @property
    def local_xy(self) -> np.ndarray:
        """Endpoints (K, 2) [m] in the laser frame."""
        return np.column_stack((self.ranges * np.cos(self.angles), self.ranges * np.sin(self.angles)))


@dataclass
class MapTables:
    """Where compiled code finds the cells of N particles' maps (all in one PatchPool).

    Patch (py, px) of particle i is pool slot slots[offset[i] + (py - py0[i]) * cols[i] +
    (px - px0[i])] when inside its rows x cols box, -1 where none is allocated.
    """
    store: np.ndarray        # the pool's (slots, LAYERS, P, P) float32
    py0: np.ndarray          # (N,) int64
    px0: np.ndarray          # (N,) int64
    rows: np.ndarray         # (N,) int64
    cols: np.ndarray         # (N,) int64
    offset: np.ndarray       # (N,) int64
    slots: np.ndarray        # (sum rows*cols,) int64
    resolution: float        # [m/cell]


# ------------------------------------------------------------------ beams
def select_beams(ranges: np.ndarray, angles: np.ndarray, max_urange: float, max_range: float,
                 lskip: int) -> Beams:
    """Beams used by the matcher: every (lskip+1)-th, finite, 0 < r < min(maxUrange, maxRange)."""
    r = np.asarray(ranges, float)
    a = np.asarray(angles, float)
    keep = np.zeros(r.shape, bool)
    keep[::lskip + 1] = True
    with np.errstate(invalid="ignore"):
        keep &= np.isfinite(r) & (r > 0.0) & (r < max_urange) & (r < max_range)
    return Beams(ranges=r[keep], angles=a[keep])


def laser_poses(base_poses: np.ndarray, laser_in_base: np.ndarray) -> np.ndarray:
    """Laser poses (..., 3) in the world from base poses (..., 3) and the laser mount (3,)."""
    c, s = np.cos(base_poses[..., 2]), np.sin(base_poses[..., 2])
    out = np.empty_like(base_poses)
    out[..., 0] = base_poses[..., 0] + c * laser_in_base[0] - s * laser_in_base[1]
    out[..., 1] = base_poses[..., 1] + s * laser_in_base[0] + c * laser_in_base[1]
    out[..., 2] = base_poses[..., 2] + laser_in_base[2]
    return out


def endpoints(base_poses: np.ndarray, laser_in_base: np.ndarray, local_xy: np.ndarray) -> np.ndarray:
    """Beam endpoints (..., K, 2) [m] in the world for base poses (..., 3).

    local_xy: (K, 2) endpoints in the laser frame (Beams.local_xy).
    """
    lp = laser_poses(np.asarray(base_poses, float), laser_in_base)
    c, s = np.cos(lp[..., 2])[..., None], np.sin(lp[..., 2])[..., None]
    bx, by = local_xy[:, 0], local_xy[:, 1]
    return np.stack((lp[..., 0:1] + c * bx - s * by, lp[..., 1:2] + s * bx + c * by), axis=-1)


def map_tables(grids: Sequence[PatchGrid]) -> MapTables:
    """MapTables of grids sharing one PatchPool (the filter's particles)."""
    pool = grids[0].pool
    if any(g.pool is not pool for g in grids):
        raise ValueError("map_tables: the grids must share one PatchPool")
    tabs = [g.patch_table() for g in grids]
    sizes = np.array([t[2] * t[3] for t in tabs], np.int64)
    return MapTables(store=pool.store,
                     py0=np.array([t[0] for t in tabs], np.int64), px0=np.array([t[1] for t in tabs], np.int64),
                     rows=np.array([t[2] for t in tabs], np.int64), cols=np.array([t[3] for t in tabs], np.int64),
                     offset=np.concatenate(([0], np.cumsum(sizes)[:-1])).astype(np.int64),
                     slots=np.concatenate([t[4] for t in tabs]), resolution=grids[0].resolution)


# ------------------------------------------------------------ compiled core
def _args(t: MapTables):
    return t.store, PATCH_SHIFT, t.py0, t.px0, t.rows, t.cols, t.offset, t.slots


def _beam_args(base_poses, laser_in_base, beams: Beams):
    poses = np.ascontiguousarray(base_poses, np.float64)
    bxy = beams.local_xy
    return (poses, len(poses), np.ascontiguousarray(laser_in_base, np.float64), np.ascontiguousarray(bxy[:, 0]),
            np.ascontiguousarray(bxy[:, 1]), len(bxy))


def likelihood_and_score(tables: MapTables, base_poses: np.ndarray, laser_in_base: np.ndarray,
                         beams: Beams, sigma: float, lsigma: float, kernel_size: int):
    """(log-likelihoods (N,), scores (N,)) of particle i at base_poses[i] (N, 3) in its own
    map: gmapping's likelihoodAndScore."""
    args = _beam_args(base_poses, laser_in_base, beams)
    logliks, scores = np.empty(args[1]), np.empty(args[1])
    _native().snc_likelihoods(*_args(tables), *args, tables.resolution, float(sigma), float(lsigma),
                              int(kernel_size), NULL_LIKELIHOOD / lsigma, logliks, scores)
    return logliks, scores


def optimize(tables: MapTables, init_poses: np.ndarray, laser_in_base: np.ndarray, beams: Beams,
             sigma: float, kernel_size: int, lstep: float, astep: float, iterations: int):
    """gmapping's ScanMatcher::optimize of particle i from init_poses[i] (N, 3) in its own
    map. Returns (poses (N, 3), best scores (N,))."""
    args = _beam_args(init_poses, laser_in_base, beams)
    poses, scores = np.empty((args[1], 3)), np.empty(args[1])
    _native().snc_optimize(*_args(tables), *args, tables.resolution, float(sigma), int(kernel_size), float(lstep),
                           float(astep), int(iterations), MOVES, len(MOVES), MAX_CLIMB_STEPS, poses, scores)
    return poses, scores


# ------------------------------------------------------------- reference
def score_reference(grid: PatchGrid, base_pose, laser_in_base, beams: Beams, sigma: float,
                    kernel_size: int, lsigma: float = None):
    """Slow, obvious version of the score (and log-likelihood when lsigma is given).

    For each beam: the endpoint, its cell, and a brute-force search of the +-kernel_size
    cells around it for the occupied one whose mean hit point is nearest. Test oracle for
    the compiled `likelihood_and_score` / `optimize`.
    """
    res = grid.resolution
    lp = laser_poses(np.asarray(base_pose, float)[None, :], np.asarray(laser_in_base, float))[0]
    cl, sl = math.cos(lp[2]), math.sin(lp[2])
    total_s, total_l = 0.0, 0.0
    for bx, by in beams.local_xy:
        ex, ey = lp[0] + cl * bx - sl * by, lp[1] + sl * bx + cl * by
        ix, iy = math.floor(ex / res), math.floor(ey / res)
        best = None
        for dy in range(-kernel_size, kernel_size + 1):
            for dx in range(-kernel_size, kernel_size + 1):
                hits, visits, sx, sy = (float(v) for v in grid.read_layers(ix + dx, iy + dy, 1, 1)[:, 0, 0])
                if visits > 0.0 and hits > FULLNESS_THRESHOLD * visits:
                    d2 = ((ix + dx) * res + sx / hits - ex) ** 2 + ((iy + dy) * res + sy / hits - ey) ** 2
                    best = d2 if best is None else min(best, d2)
        if best is None:
            total_l += NULL_LIKELIHOOD / (lsigma or 1.0)
        else:
            total_s += math.exp(-best / sigma)
            total_l += -best / (lsigma or 1.0)
    return (total_s, total_l) if lsigma is not None else total_s


def optimize_reference(grid: PatchGrid, init_pose, laser_in_base, beams: Beams, sigma: float,
                       kernel_size: int, lstep: float, astep: float, iterations: int):
    """Plain sequential ScanMatcher::optimize on score_reference (oracle for `optimize`)."""
    def score(pose):
        return score_reference(grid, pose, laser_in_base, beams, sigma, kernel_size)

    current = np.asarray(init_pose, float).copy()
    current_score = score(current)
    best_score = -1.0
    ldelta, adelta = lstep, astep
    refinement = 0
    while True:
        if best_score >= current_score:
            refinement += 1
            ldelta *= 0.5
            adelta *= 0.5
        best_score = current_score
        best_local = current
        for move in MOVES:  # front, back, left, right, turn left, turn right
            local = current + move * (ldelta, ldelta, adelta)
            local_score = score(local)
            if local_score > current_score:
                current_score = local_score
                best_local = local
        current = best_local
        if not (current_score > best_score or refinement < iterations):
            break
    current[2] = math.atan2(math.sin(current[2]), math.cos(current[2]))
    return current, best_score
