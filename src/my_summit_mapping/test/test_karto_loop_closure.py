"""Loop closure bookkeeping: near-linked nodes, candidate chains, and a wrong loop edge
rejected after optimization while the right one is kept."""
import math

import numpy as np
from numpy.testing import assert_allclose

from my_summit_mapping.karto import loop_closure as lc
from my_summit_mapping.karto.optimizer import optimize, optimize_graph
from my_summit_mapping.karto.pose_graph import Node, PoseGraph, between, compose
from my_summit_mapping.karto.pose_graph import weighted_mean, wrap


def square_loop():
    """True poses (K, 3) of a 4 m x 3 m loop driven counter-clockwise in 0.5 m steps."""
    poses = []
    x, y, th = 0.0, 0.0, 0.0
    for length in (4.0, 3.0, 4.0, 3.0):
        for _ in range(int(length / 0.5)):
            poses.append((x, y, th))
            x += 0.5 * math.cos(th)
            y += 0.5 * math.sin(th)
        th = float(wrap(th + math.pi / 2))
    return np.array(poses)

SEQ_COV = np.diag([0.02 ** 2, 0.02 ** 2, math.radians(0.5) ** 2])   # [m^2, m^2, rad^2]
LOOP_COV = np.diag([0.03 ** 2, 0.03 ** 2, math.radians(1.0) ** 2])


def drifted_graph():
    """The square loop of test_karto_optimizer driven with a heading drift: sequential
    edges measured from the truth, node poses chained from drifted increments."""
    truth = square_loop()
    g = PoseGraph()
    pose = truth[0].copy()
    for k, p in enumerate(truth):
        if k:
            step = between(truth[k - 1], p)
            step[2] += 0.01           # the drift [rad per step]
            pose = compose(pose, step)
        g.add_node(Node(k, float(k), p.copy(), pose.copy(), np.zeros(1, np.float32), np.zeros((0, 2)), np.zeros(2)))
        if k:
            g.add_edge(k - 1, k, "sequential", between(truth[k - 1], p), covariance=SEQ_COV)
    return g, truth


def close_with(g, truth, measurement, max_correction):
    """Optimize without, then with a loop edge 0 -> last (as the mapper does); check it."""
    n = len(truth) - 1
    before = g.poses()
    without = optimize_graph(g)
    edge = g.add_edge(0, n, "loop", measurement, covariance=LOOP_COV)
    i, j, z, info = g.edge_arrays()
    res = optimize(without.poses, i, j, z, info)
    why = lc.check_closure(g, edge, before, res.poses, max_correction, without.chi2_after, res.chi2_after)
    return why, res.poses


def test_right_loop_edge_is_kept_and_fixes_the_drift():
    g, truth = drifted_graph()
    n = len(truth) - 1
    drift_before = np.hypot(*(g.poses()[n, :2] - truth[n, :2]))
    why, after = close_with(g, truth, between(truth[0], truth[n]), max_correction=3.0)
    assert why is None
    assert drift_before > 0.3
    assert_allclose(after[:, :2], truth[:, :2], atol=1e-6)


def test_wrong_loop_edge_is_rejected_by_its_residual():
    g, truth = drifted_graph()
    n = len(truth) - 1
    wrong = compose(between(truth[0], truth[n]), np.array([1.5, 0.0, 0.0]))   # 1.5 m off
    why, _ = close_with(g, truth, wrong, max_correction=10.0)
    assert why is not None and "chi2" in why, why
    # a small disagreement, within the edges' covariances, is kept
    g, truth = drifted_graph()
    assert close_with(g, truth, compose(between(truth[0], truth[n]), np.array([0.05, 0.0, 0.0])), 10.0)[0] is None


def test_loop_edge_moving_nodes_too_far_is_rejected():
    g, truth = drifted_graph()
    n = len(truth) - 1
    why, _ = close_with(g, truth, between(truth[0], truth[n]), max_correction=0.5)
    assert why is not None and "loop_closure_max_correction" in why


def test_candidate_chain_skips_near_linked_nodes():
    # nodes 0..29 on a line, node 30 back at x = 1: nodes 0..14 lie within 4 m of it
    g = PoseGraph()
    for k in range(31):
        x = 0.2 * k if k < 30 else 1.0
        g.add_node(Node(k, float(k), np.array([x, 0.0, 0.0]), np.array([x, 0.0, 0.0]), np.zeros(1, np.float32),
                        np.zeros((0, 2)), np.zeros(2)))
        if 0 < k < 30:
            g.add_edge(k - 1, k, "sequential", [0.2, 0.0, 0.0], covariance=SEQ_COV)
    g.add_edge(29, 30, "sequential", [1.0 - 5.8, 0.0, 0.0], covariance=SEQ_COV)
    pos = g.positions(False)
    near = lc.near_linked(g, 30, 4.0, pos)
    assert near == {30}                       # node 29 is 4.8 m away: the chain is broken
    chain, nxt = lc.candidate_chain(30, near, 4.0, 10, pos)
    assert chain == list(range(0, 26)) and nxt == 27   # x <= 5.0
    # the same nodes tied to node 30 by an edge are near-linked: no candidate
    g.add_edge(5, 30, "sequential", [0.0, 0.0, 0.0], covariance=SEQ_COV)
    near = lc.near_linked(g, 30, 4.0, pos)
    assert set(range(0, 26)) <= near
    assert lc.candidate_chain(30, near, 4.0, 10, pos)[0] == []


def test_weighted_mean_is_the_product_of_the_gaussians():
    """open_karto's ComputeWeightedMean: each axis leans to the match that knows it best,
    and headings either side of +-pi average across it, not through 0."""
    a = np.array([1.0, 2.0, math.pi - 0.02])
    b = np.array([1.4, 2.6, -math.pi + 0.04])
    cov_a = np.diag([0.01, 1.0, 0.01])      # a knows x
    cov_b = np.diag([1.0, 0.01, 0.01])      # b knows y
    mean = weighted_mean([a, b], [cov_a, cov_b])
    assert_allclose(mean[:2], [1.0 + 0.4 * 0.01 / 1.01, 2.6 - 0.6 * 0.01 / 1.01], atol=1e-9)
    assert_allclose(wrap(mean[2] - (math.pi + 0.01)), 0.0, atol=1e-9)
    assert_allclose(weighted_mean([a], [cov_a]), a, atol=1e-12)
