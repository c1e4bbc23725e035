"""Grid line traversal: the cells of straight lines between cells, for the whole workspace.

Algorithm: Bresenham's line (Bresenham 1965, "Algorithm for computer control of a digital
plotter"), in closed form: a line from cell (x0, y0) to (x1, y1) has n = max(|dx|, |dy|)
steps; after step k (0..n, both ends included) it is at (x0 + round(k dx / n),
y0 + round(k dy / n)), so the major axis moves one cell a step and the minor one is
rounded. Two tie rules are in use, each the one of the code it stands for:
- ``"away"`` (halves away from zero): costmap_2d's raytraceLine and base_local_planner's
  LineIterator (the costmap layers' clearing, TrajectoryPlanner's footprint outline);
- ``"up"`` (halves towards +inf): gmapping's GridLineTraversal (the SLAM grid).
round(k d / n) is computed as floor((2 k |d| + n) / (2 n)) in float64: numerator and
denominator are integers far below 2^53 and IEEE division is correctly rounded, so an
integer quotient is exact and any other stays 1 / (2 n) from the next integer (about
twice as fast as NumPy's integer floor division, and the same cells).

``line_cells`` lays every line's cells end to end (line index, x, y);
``line_cells_padded`` gives lines as rows padded to the longest (xs, ys, valid);
``line_cells_reference`` is the slow, obvious walk with exact fractions: the one oracle.
"""
from fractions import Fraction
import math

import numpy as np

TIES = ("away", "up")


def rounded_steps(k, d, n, ties="away"):
    """round(k d / n) (int64), k, d integer arrays, n > 0 integer array (broadcast);
    halves away from zero (ties "away") or towards +inf ("up")."""
    k = np.asarray(k, dtype=np.int64)
    d = np.asarray(d, dtype=np.int64)
    n = np.asarray(n, dtype=np.int64)
    if ties == "up":
        return np.floor((2 * k * d + n) / (2.0 * n)).astype(np.int64)
    if ties == "away":
        return np.sign(d) * np.floor((2 * k * np.abs(d) + n) / (2.0 * n)).astype(np.int64)
    raise ValueError(f"ties must be one of {TIES}, got {ties!r}")


def line_cells(x0, y0, x1, y1, ties="away"):
    """Cells of lines from (x0, y0) to (x1, y1) (integer scalars or arrays, broadcast),
    ends included: (line index (M,), x (M,), y (M,)) int64, each line's cells in order."""
    x0, y0, x1, y1 = (np.asarray(v, dtype=np.int64).ravel() for v in np.broadcast_arrays(x0, y0, x1, y1))
    dx, dy = x1 - x0, y1 - y0
    n = np.maximum(np.abs(dx), np.abs(dy))
    counts = n + 1
    line = np.repeat(np.arange(n.size), counts)
    k = np.arange(line.size) - np.repeat(np.cumsum(counts) - counts, counts)
    nn = np.maximum(n, 1)[line]
    return (line, x0[line] + rounded_steps(k, dx[line], nn, ties),
            y0[line] + rounded_steps(k, dy[line], nn, ties))


def line_cells_padded(x0, y0, x1, y1, ties="away"):
    """Cells of lines from (x0, y0) to (x1, y1) (integer arrays of one shape S), ends
    included, as rows: (xs, ys, valid) each S + (L,), L the longest line's cell count;
    valid marks the cells each line really has (the others are past its end)."""
    x0, y0, x1, y1 = (np.asarray(v, dtype=np.int64) for v in (x0, y0, x1, y1))
    dx, dy = (x1 - x0)[..., None], (y1 - y0)[..., None]
    n = np.maximum(np.abs(dx), np.abs(dy))
    k = np.arange(int(n.max()) + 1 if n.size else 1)
    nn = np.maximum(n, 1)
    return (x0[..., None] + rounded_steps(k, dx, nn, ties), y0[..., None] + rounded_steps(k, dy, nn, ties),
            k <= n)


def line_cells_reference(x0, y0, x1, y1, ties="away"):
    """The cells [(x, y), ...] of one line, ends included, by exact fractions (the oracle)."""
    if ties not in TIES:
        raise ValueError(f"ties must be one of {TIES}, got {ties!r}")
    dx, dy = x1 - x0, y1 - y0
    n = max(abs(dx), abs(dy))

    def rnd(q):
        if ties == "up":
            return math.floor(q + Fraction(1, 2))
        return int(math.copysign(math.floor(abs(q) + Fraction(1, 2)), q))
    return [(x0 + rnd(Fraction(k * dx, max(n, 1))), y0 + rnd(Fraction(k * dy, max(n, 1)))) for k in range(n + 1)]
