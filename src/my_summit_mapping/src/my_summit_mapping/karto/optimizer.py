"""Sparse Levenberg-Marquardt on an SE(2) pose graph.

Reference: Konolige, Grisetti, Kuemmerle, Burgard, Limketkai, Vincent 2010, "Efficient
Sparse Pose Adjustment for 2D Mapping" (SPA, the solver slam_karto uses); Grisetti et al.
2010, "A Tutorial on Graph-Based SLAM" (error, Jacobians, the linear system).

For an edge (i, j) with measurement z (pose of j in i's frame) and information Omega:
    e = ( R_i^T (t_j - t_i) - z_t ,  wrap(th_j - th_i - z_th) )
    chi2 = sum over edges of e^T Omega e
Each iteration builds the sparse Jacobian J (3E x 3N; each edge touches two 3x3 blocks),
whitens it with Omega = S^T S (S from a Cholesky factor), solves
    (J^T Omega J + lambda * diag(J^T Omega J)) dx = -J^T Omega e
with SuperLU (scipy.sparse.linalg.spsolve) with node `fixed` held (its columns removed:
the map frame's gauge), and keeps a step only when chi2 drops (lambda shrinks), else
raises lambda (Marquardt's damping). Stops when the relative chi2 change or the step is
below tolerance, or after max_iterations.
"""
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from .pose_graph import wrap

MAX_ITERATIONS = 20        # [-]
RELATIVE_TOLERANCE = 1e-6  # stop when chi2 changes by less than this fraction [-]
STEP_TOLERANCE = 1e-7      # stop when the largest update is below this [m, rad]
INITIAL_LAMBDA = 1e-4      # Marquardt damping at the start [-]
LAMBDA_UP, LAMBDA_DOWN = 10.0, 0.1  # damping factors after a rejected / accepted step [-]
MAX_LAMBDA = 1e8           # give up raising the damping beyond this [-]


@dataclass
class OptimizeResult:
    poses: np.ndarray   # (N, 3) optimized [m, m, rad]
    chi2_before: float
    chi2_after: float
    iterations: int


def residuals(poses: np.ndarray, i: np.ndarray, j: np.ndarray, z: np.ndarray) -> np.ndarray:
    """Edge errors (E, 3) of poses (N, 3) for edges i -> j with measurements z (E, 3)."""
    pi, pj = poses[i], poses[j]
    c, s = np.cos(pi[:, 2]), np.sin(pi[:, 2])
    dx, dy = pj[:, 0] - pi[:, 0], pj[:, 1] - pi[:, 1]
    return np.column_stack((c * dx + s * dy - z[:, 0], -s * dx + c * dy - z[:, 1],
                            wrap(pj[:, 2] - pi[:, 2] - z[:, 2])))


def chi2_per_edge(poses, i, j, z, info) -> np.ndarray:
    """e^T Omega e of each edge (E,)."""
    e = residuals(poses, i, j, z)
    return np.einsum("ea,eab,eb->e", e, info, e)


def jacobian_blocks(poses: np.ndarray, i: np.ndarray, j: np.ndarray):
    """d e / d x_i (E, 3, 3) and d e / d x_j (E, 3, 3) of residuals()."""
    pi, pj = poses[i], poses[j]
    c, s = np.cos(pi[:, 2]), np.sin(pi[:, 2])
    dx, dy = pj[:, 0] - pi[:, 0], pj[:, 1] - pi[:, 1]
    n = len(i)
    a = np.zeros((n, 3, 3))
    a[:, 0, 0], a[:, 0, 1], a[:, 0, 2] = -c, -s, -s * dx + c * dy
    a[:, 1, 0], a[:, 1, 1], a[:, 1, 2] = s, -c, -c * dx - s * dy
    a[:, 2, 2] = -1.0
    b = np.zeros((n, 3, 3))
    b[:, 0, 0], b[:, 0, 1] = c, s
    b[:, 1, 0], b[:, 1, 1] = -s, c
    b[:, 2, 2] = 1.0
    return a, b


def _whitening(info: np.ndarray) -> np.ndarray:
    """S (E, 3, 3) with S^T S = Omega (upper Cholesky factor of each information matrix)."""
    return np.transpose(np.linalg.cholesky(info), (0, 2, 1))


def optimize(poses: np.ndarray, i, j, z, info, fixed: int = 0,
             max_iterations: int = MAX_ITERATIONS) -> OptimizeResult:
    """Levenberg-Marquardt (module docstring) from initial poses (N, 3); edges i, j (E,),
    measurements z (E, 3), information (E, 3, 3). Node `fixed` does not move."""
    x = np.array(poses, float).reshape(-1, 3)
    i, j = np.asarray(i, int), np.asarray(j, int)
    z, info = np.asarray(z, float).reshape(-1, 3), np.asarray(info, float).reshape(-1, 3, 3)
    n_nodes, n_edges = len(x), len(i)
    chi2 = float(chi2_per_edge(x, i, j, z, info).sum()) if n_edges else 0.0
    start = chi2
    if n_edges == 0 or n_nodes < 2:
        return OptimizeResult(x, start, chi2, 0)
    sqrt_info = _whitening(info)
    keep = np.ones(3 * n_nodes, bool)
    keep[3 * fixed:3 * fixed + 3] = False
    rows = np.repeat(np.arange(3 * n_edges).reshape(n_edges, 3), 3, axis=1)   # (E, 9)
    lam = INITIAL_LAMBDA
    it = 0
    for it in range(1, max_iterations + 1):
        e = residuals(x, i, j, z)
        a, b = jacobian_blocks(x, i, j)
        wa, wb = sqrt_info @ a, sqrt_info @ b                 # whitened blocks (E, 3, 3)
        we = np.einsum("eab,eb->ea", sqrt_info, e)
        cols_i = (3 * i[:, None] + np.tile(np.arange(3), 3)[None, :])
        cols_j = (3 * j[:, None] + np.tile(np.arange(3), 3)[None, :])
        data = np.concatenate((wa.reshape(-1), wb.reshape(-1)))
        r = np.concatenate((rows.reshape(-1), rows.reshape(-1)))
        col = np.concatenate((cols_i.reshape(-1), cols_j.reshape(-1)))
        jac = sp.csr_matrix((data, (r, col)), shape=(3 * n_edges, 3 * n_nodes))[:, keep]
        h = (jac.T @ jac).tocsc()
        g = jac.T @ we.reshape(-1)
        diag = h.diagonal()
        improved = False
        while lam <= MAX_LAMBDA:
            damped = h + sp.diags(lam * np.maximum(diag, 1e-12), format="csc")
            step = spla.spsolve(damped, -g)
            trial = x.copy()
            trial.reshape(-1)[keep] += step
            trial[:, 2] = wrap(trial[:, 2])
            new_chi2 = float(chi2_per_edge(trial, i, j, z, info).sum())
            if np.isfinite(new_chi2) and new_chi2 <= chi2:
                improved = True
                break
            lam *= LAMBDA_UP
        if not improved:
            break
        change = chi2 - new_chi2
        x, chi2 = trial, new_chi2
        lam = max(lam * LAMBDA_DOWN, 1e-12)
        if change <= RELATIVE_TOLERANCE * max(chi2, 1e-12) or np.max(np.abs(step)) < STEP_TOLERANCE:
            break
    return OptimizeResult(x, start, chi2, it)


def optimize_graph(graph, fixed: int = 0, max_iterations: int = MAX_ITERATIONS) -> OptimizeResult:
    """optimize() on a PoseGraph's poses and edges (the graph is not changed)."""
    i, j, z, info = graph.edge_arrays()
    return optimize(graph.poses(), i, j, z, info, fixed, max_iterations)
