"""SE(2) pose graph: scans as nodes, odometry / scan-match / loop constraints as edges.

Reference: Lu & Milios 1997, "Globally consistent range scan alignment for environment
mapping" (the graph formulation); Konolige et al. 2010, "Efficient Sparse Pose Adjustment
for 2D Mapping" (SPA, open_karto's solver): an edge (i, j) holds the measured pose of node
j in node i's frame and its 3x3 information matrix (the inverse covariance of the match
that produced it).

A node keeps its scan (ranges as received), the hit points in the base frame used for
matching, its odometry pose and its corrected (optimized) pose in the map frame.
"""
import math
from collections import OrderedDict
from dataclasses import dataclass, field
from typing import Dict, List, Set

import numpy as np

EDGE_KINDS = ("odometry", "sequential", "loop")


def wrap(angle):
    """Angle(s) wrapped to [-pi, pi) [rad]."""
    return (np.asarray(angle) + math.pi) % (2.0 * math.pi) - math.pi


def compose(a, b) -> np.ndarray:
    """SE(2) product a * b of poses (3,) [m, m, rad]."""
    c, s = math.cos(a[2]), math.sin(a[2])
    return np.array([a[0] + c * b[0] - s * b[1], a[1] + s * b[0] + c * b[1], float(wrap(a[2] + b[2]))])


def inverse(a) -> np.ndarray:
    """SE(2) inverse of pose a (3,)."""
    c, s = math.cos(a[2]), math.sin(a[2])
    return np.array([-c * a[0] - s * a[1], s * a[0] - c * a[1], float(wrap(-a[2]))])


def between(a, b) -> np.ndarray:
    """Pose of b in a's frame: inverse(a) * b."""
    return compose(inverse(a), b)


def weighted_mean(poses, covariances) -> np.ndarray:
    """Information-weighted mean (3,) of poses (k, 3) with covariances (k, 3, 3): the
    product of their Gaussians (open_karto's ComputeWeightedMean; headings taken
    relative to the first, so that they do not straddle +-pi)."""
    p = np.array(poses, float).reshape(-1, 3)
    p[:, 2] = p[0, 2] + wrap(p[:, 2] - p[0, 2])
    info = np.array([information_of(c) for c in covariances])
    total = info.sum(axis=0)
    mean = np.linalg.solve(total, np.einsum("kab,kb->a", info, p))
    return np.array([mean[0], mean[1], float(wrap(mean[2]))])


def transform_points(pose, points: np.ndarray) -> np.ndarray:
    """Points (n, 2) of the frame at pose (3,) in the parent frame."""
    c, s = math.cos(pose[2]), math.sin(pose[2])
    p = np.asarray(points, float).reshape(-1, 2)
    return np.column_stack((pose[0] + c * p[:, 0] - s * p[:, 1], pose[1] + s * p[:, 0] + c * p[:, 1]))


@dataclass
class Node:
    id: int
    stamp: float               # scan time [s]
    odom_pose: np.ndarray      # (3,) base pose in the odometry frame [m, m, rad]
    pose: np.ndarray           # (3,) corrected base pose in the map frame [m, m, rad]
    ranges: np.ndarray         # (n,) float32 ranges as received [m]
    points: np.ndarray         # (k, 2) hit points used for matching, base frame [m] (float32,
                               # a view of the reference's first rows: KartoMapper._points_and_reference)
    barycenter: np.ndarray     # (2,) mean of points, base frame [m] (the node's own position if none)
    reference: np.ndarray = None  # (m, 2) points this scan offers as a reference, base
                                  # frame [m] (points if None)
    # (pose bytes, reference_in_map at that pose): a node's reference is read for every
    # match near it, ~140 times per node on Intel, and its pose changes far less often
    _reference_cache: tuple = field(default=None, repr=False, compare=False)
    # (min_offset, beam indices): the mixed pixels the map leaves out (KartoMapper._mixed)
    mixed: tuple = field(default=None, repr=False, compare=False)

    def points_in_map(self) -> np.ndarray:
        return transform_points(self.pose, self.points)

    def reference_in_map(self) -> np.ndarray:
        """The reference points in the map frame at the node's pose (read-only: shared)."""
        key = np.asarray(self.pose, float).tobytes()
        if self._reference_cache is None or self._reference_cache[0] != key:
            ref = transform_points(self.pose, self.points if self.reference is None else self.reference)
            ref = ref.astype(np.float32)    # kept for every node: half the bytes, um precision
            ref.flags.writeable = False
            self._reference_cache = (key, ref)
        return self._reference_cache[1]

    def position(self, use_barycenter: bool) -> np.ndarray:
        """Where the node is for distance tests: its scan's barycenter or its base [m]."""
        if use_barycenter:
            return transform_points(self.pose, self.barycenter[None, :])[0]
        return self.pose[:2].copy()


@dataclass
class Edge:
    i: int                     # from node
    j: int                     # to node
    kind: str                  # one of EDGE_KINDS
    measurement: np.ndarray    # (3,) pose of j in i's frame [m, m, rad]
    information: np.ndarray    # (3, 3) inverse covariance [1/m^2, 1/rad^2]


class ReferenceCache:
    """Node.reference_in_map kept for the `capacity` nodes read most recently: matches
    read the running buffer and the chains near the robot again and again, and an old
    part of the graph only when the robot comes back. Every node keeping its own (8.6 kB
    at 1081 beams) held 35 MB on willow-full's 4000 nodes."""

    def __init__(self, capacity: int):
        self.capacity = int(capacity)
        self._held: "OrderedDict[int, Node]" = OrderedDict()

    def get(self, node: Node) -> np.ndarray:
        ref = node.reference_in_map()
        self._held[node.id] = node
        self._held.move_to_end(node.id)
        while len(self._held) > self.capacity:
            _, old = self._held.popitem(last=False)
            old._reference_cache = None
        return ref

    def __len__(self) -> int:
        return len(self._held)


@dataclass
class PoseGraph:
    nodes: List[Node] = field(default_factory=list)
    edges: List[Edge] = field(default_factory=list)
    _adjacent: Dict[int, Set[int]] = field(default_factory=dict)

    def add_node(self, node: Node) -> int:
        if node.id != len(self.nodes):
            raise ValueError(f"node ids are consecutive: expected {len(self.nodes)}, got {node.id}")
        self.nodes.append(node)
        self._adjacent[node.id] = set()
        return node.id

    def add_edge(self, i: int, j: int, kind: str, measurement, covariance=None, information=None) -> Edge:
        """Add a constraint: node j seen from node i at `measurement`, with either its
        covariance or its information matrix (3, 3)."""
        if kind not in EDGE_KINDS:
            raise ValueError(f"edge kind must be one of {EDGE_KINDS}, got {kind!r}")
        if not (0 <= i < len(self.nodes) and 0 <= j < len(self.nodes)) or i == j:
            raise ValueError(f"edge ({i}, {j}) needs two different existing nodes")
        if information is None:
            information = information_of(covariance)
        edge = Edge(i, j, kind, np.asarray(measurement, float), np.asarray(information, float))
        self.edges.append(edge)
        self._adjacent[i].add(j)
        self._adjacent[j].add(i)
        return edge

    def remove_edge(self, edge: Edge) -> None:
        self.edges.remove(edge)
        if not any({e.i, e.j} == {edge.i, edge.j} for e in self.edges):
            self._adjacent[edge.i].discard(edge.j)
            self._adjacent[edge.j].discard(edge.i)

    def neighbours(self, i: int) -> Set[int]:
        return self._adjacent[i]

    def poses(self) -> np.ndarray:
        return np.array([n.pose for n in self.nodes]).reshape(-1, 3)

    def set_poses(self, poses: np.ndarray) -> None:
        for node, p in zip(self.nodes, poses):
            node.pose = np.array([p[0], p[1], float(wrap(p[2]))])

    def positions(self, use_barycenter: bool) -> np.ndarray:
        """Node.position of every node (N, 2) [m], in one vectorized step."""
        poses = self.poses()
        if not use_barycenter or not len(poses):
            return poses[:, :2].copy()
        b = np.array([n.barycenter for n in self.nodes])
        c, s = np.cos(poses[:, 2]), np.sin(poses[:, 2])
        return np.column_stack((poses[:, 0] + c * b[:, 0] - s * b[:, 1], poses[:, 1] + s * b[:, 0] + c * b[:, 1]))

    def edge_arrays(self):
        """(i (E,), j (E,), measurements (E, 3), information (E, 3, 3)) for the optimizer."""
        if not self.edges:
            return (np.zeros(0, int), np.zeros(0, int), np.zeros((0, 3)), np.zeros((0, 3, 3)))
        return (np.array([e.i for e in self.edges]), np.array([e.j for e in self.edges]),
                np.array([e.measurement for e in self.edges]), np.array([e.information for e in self.edges]))


def information_of(covariance) -> np.ndarray:
    """Inverse of a 3x3 covariance, symmetrized (a singular one raises ValueError)."""
    cov = np.asarray(covariance, float)
    try:
        info = np.linalg.inv(cov)
    except np.linalg.LinAlgError as exc:
        raise ValueError(f"edge covariance is singular: {cov.tolist()}") from exc
    return 0.5 * (info + info.T)
