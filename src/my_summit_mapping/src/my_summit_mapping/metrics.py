"""SLAM quality metrics: absolute trajectory error and map precision/recall.

References: ATE as in Sturm et al. 2012, "A Benchmark for the Evaluation of RGB-D SLAM
Systems" (RMSE of positions after the best rigid alignment); the alignment is the
closed-form least-squares rigid transform of Umeyama 1991, "Least-squares estimation of
transformation parameters between two point patterns" (Horn's method in 2D), without
scale. Map precision/recall against a reference wall grid with a one-cell tolerance.
"""
from typing import Optional, Tuple

import cv2
import numpy as np

WALL_TOLERANCE_CELLS = 1  # a map cell within this many cells (8-neighbourhood) of a wall counts [cells]


def rigid_alignment_2d(source: np.ndarray, target: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
    """Rotation R (2, 2) and translation t (2,) minimizing sum |R s_i + t - t_i|^2 (Umeyama).

    source, target: (K, 2) corresponding positions [m], K >= 2.
    """
    src = np.asarray(source, float)[:, :2]
    dst = np.asarray(target, float)[:, :2]
    if src.shape != dst.shape or len(src) < 2:
        raise ValueError(f"need two equally long trajectories of >= 2 positions, got "
                         f"{src.shape} and {dst.shape}")
    mu_s, mu_d = src.mean(axis=0), dst.mean(axis=0)
    cov = (dst - mu_d).T @ (src - mu_s) / len(src)
    u, _, vt = np.linalg.svd(cov)
    sign = np.eye(2)
    if np.linalg.det(u) * np.linalg.det(vt) < 0.0:  # no reflections
        sign[1, 1] = -1.0
    rot = u @ sign @ vt
    return rot, mu_d - rot @ mu_s


def ate_rmse(estimate: np.ndarray, reference: np.ndarray) -> float:
    """Absolute trajectory error [m]: position RMSE after the best rigid 2D alignment.

    estimate, reference: (K, 2+) corresponding poses (x, y[, theta]) [m].
    """
    rot, t = rigid_alignment_2d(estimate, reference)
    aligned = np.asarray(estimate, float)[:, :2] @ rot.T + t
    err = aligned - np.asarray(reference, float)[:, :2]
    return float(np.sqrt(np.mean(np.sum(err * err, axis=1))))


def _near(mask: np.ndarray, tolerance: int = WALL_TOLERANCE_CELLS) -> np.ndarray:
    kernel = np.ones((2 * tolerance + 1,) * 2, np.uint8)
    return cv2.dilate(mask.astype(np.uint8), kernel).astype(bool)


def map_precision(occupied: np.ndarray, walls: np.ndarray) -> float:
    """Share of occupied map cells within one cell of a true wall cell [0..1].

    occupied, walls: boolean grids of the same shape, aligned cell for cell. NaN when
    the map has no occupied cell.
    """
    _check_shapes(occupied, walls)
    occ = np.asarray(occupied, bool)
    n = int(occ.sum())
    return float(np.sum(occ & _near(walls))) / n if n else float("nan")


def map_recall(occupied: np.ndarray, walls: np.ndarray, seen: Optional[np.ndarray] = None) -> float:
    """Share of seen true wall cells that have an occupied map cell within one cell [0..1].

    seen: boolean grid of cells the laser observed (e.g. map != -1); a wall cell counts
    as seen when a seen cell lies within one cell of it. None: every wall cell counts.
    NaN when no wall cell was seen.
    """
    _check_shapes(occupied, walls)
    wall = np.asarray(walls, bool)
    if seen is not None:
        _check_shapes(seen, walls)
        wall = wall & _near(seen)
    n = int(wall.sum())
    return float(np.sum(wall & _near(occupied))) / n if n else float("nan")


def _check_shapes(a, b):
    if np.shape(a) != np.shape(b):
        raise ValueError(f"grids must be aligned and equally sized, got {np.shape(a)} and {np.shape(b)}")
