"""Sparse LM on SE(2): Jacobians against finite differences; a hand-built loop converges
to its known solution; the first node stays fixed."""
import math

import numpy as np
from numpy.testing import assert_allclose

from my_summit_mapping.karto import optimizer as opt
from my_summit_mapping.karto.pose_graph import between, wrap

# a 4 m x 3 m loop driven counter-clockwise, 0.5 m steps (true poses) [m, m, rad]


def square_loop():
    poses = []
    x, y, th = 0.0, 0.0, 0.0
    for side, length in enumerate((4.0, 3.0, 4.0, 3.0)):
        for _ in range(int(length / 0.5)):
            poses.append((x, y, th))
            x += 0.5 * math.cos(th)
            y += 0.5 * math.sin(th)
        th = float(wrap(th + math.pi / 2))
    return np.array(poses)


def chain_edges(truth):
    i = np.arange(len(truth) - 1)
    return i, i + 1


def test_jacobians_match_finite_differences():
    rng = np.random.default_rng(0)
    poses = rng.uniform(-2, 2, (2, 3))
    z = rng.uniform(-1, 1, (1, 3))
    i, j = np.array([0]), np.array([1])
    a, b = opt.jacobian_blocks(poses, i, j)
    eps = 1e-7
    for node, block in ((0, a[0]), (1, b[0])):
        for k in range(3):
            p = poses.copy()
            p[node, k] += eps
            num = (opt.residuals(p, i, j, z) - opt.residuals(poses, i, j, z))[0] / eps
            assert_allclose(block[:, k], num, atol=1e-5)


def test_loop_converges_to_the_known_solution():
    truth = square_loop()
    n = len(truth)
    ci, cj = chain_edges(truth)
    i = np.append(ci, n - 1)
    j = np.append(cj, 0)                                     # the loop edge
    z = np.array([between(truth[a], truth[b]) for a, b in zip(i, j)])
    info = np.repeat(np.diag([100.0, 100.0, 400.0])[None], len(i), axis=0)
    rng = np.random.default_rng(4)
    start = truth.copy()
    # drifted start: every pose after the first carries an accumulated heading error
    drift = np.cumsum(rng.normal(0, 0.03, n))
    drift[0] = 0.0
    start[:, 2] += drift
    start[1:, :2] += np.cumsum(rng.normal(0, 0.05, (n - 1, 2)), axis=0)
    res = opt.optimize(start, i, j, z, info)
    assert res.chi2_after < 1e-10 < res.chi2_before
    assert_allclose(res.poses[:, :2], truth[:, :2], atol=1e-6)
    assert_allclose(wrap(res.poses[:, 2] - truth[:, 2]), 0.0, atol=1e-6)
    assert_allclose(res.poses[0], start[0])                  # the fixed node


def test_inconsistent_measurements_share_the_error_by_information():
    # two nodes, two edges disagreeing by 0.1 m in x: the result is their weighted mean
    z = np.array([[1.0, 0.0, 0.0], [1.1, 0.0, 0.0]])
    info = np.array([np.diag([300.0, 1.0, 1.0]), np.diag([100.0, 1.0, 1.0])])
    res = opt.optimize(np.zeros((2, 3)), np.array([0, 0]), np.array([1, 1]), z, info)
    assert_allclose(res.poses[1], [1.025, 0.0, 0.0], atol=1e-9)
