"""KartoMapper: graph SLAM as open_karto's Mapper runs it, with SPA-style optimization.

API beyond the one agreed with the node (issue 42), all additions: KartoParams has
`range_threshold` (open_karto's laser RangeThreshold, 12 m); `take_log()` returns and
clears the notes on rejected loop closures (for the node to log); `node_stamps()`;
`stats` also counts `scans_received` and `optimizations`.

Reference: open_karto (SRI International; Konolige et al. 2010, "Efficient Sparse Pose
Adjustment for 2D Mapping") as slam_karto drives it; Olson 2009, "Real-Time Correlative
Scan Matching". The parameters are slam_karto's ROS parameters with open_karto's
defaults (KartoParams).

For each scan (add_scan):
1. Throttle: every `throttle_scans`-th scan is looked at (slam_karto); the first one
   always becomes a node, later ones when the odometry moved `minimum_travel_distance`
   or turned `minimum_travel_heading` since the last node, or `minimum_time_interval`
   passed (open_karto's HasMovedEnough).
2. Predict: the last node's correction applied to the new odometry pose.
3. Sequential match against the running buffer (the last `scan_buffer_size` nodes within
   `scan_buffer_maximum_scan_distance`), penalized, coarse then fine; the node takes the
   matched pose. Optionally (`correlation_search_max_recenters`, ours, off by default)
   the window moves onto a coarse best found at its edge, for scans so far apart that
   the odometry's error can exceed open_karto's +-0.15 m window.
4. Edges: to the previous node ("sequential", the match's covariance; "odometry" when
   scan matching is off or the match found nothing), to the closest node of the running
   buffer, and to each near chain (nodes tied to this one through the graph within
   `link_scan_maximum_distance`, not in the buffer) whose match reaches
   `link_match_minimum_response_fine` (open_karto's AddEdges / LinkNearChains).
5. Loop closing (loop_closure): candidate chains, coarse then fine match; an accepted
   match adds a "loop" edge and the graph is optimized (optimizer) without and with it;
   the closure is taken back (and logged in `log`) if it moved any node by more than
   `loop_closure_max_correction` or raised the optimum's chi2 beyond what one right
   edge adds (loop_closure.check_closure).

The graph is optimized only when a loop closes (as open_karto); the edges added in
between (running buffer, near chains) wait for the next closure.

map -> odom is the latest node's corrected pose times the inverse of its odometry pose.

The map (render) casts every node's scan from its corrected pose. With
`mixed_pixel_min_offset` (ours; off by default, as open_karto has no such step) it marks
no hit at each scan's mixed pixels (mixed_pixels) and only frees their line of sight.
Matching keeps them: on Intel's 1 deg laser, dropping beams from the match (then
laser_filters' angle test, 15 % of them) took away enough of each scan that half the
loops no longer closed (online ATE median 0.39 m instead of 0.18, seeds 1-5).
"""
import dataclasses
import math
from dataclasses import dataclass, field
from typing import Dict, List, Optional, Tuple

import numpy as np

from ..mixed_pixels import mixed_pixel_mask
from . import correlative_matcher as cm
from . import loop_closure as lc
from .optimizer import optimize, optimize_graph
from .pose_graph import Node, PoseGraph, ReferenceCache, between, compose, inverse, transform_points, weighted_mean, wrap
from .render import Renderer

ODOMETRY_COVARIANCE = (0.05 ** 2, 0.05 ** 2, math.radians(3.0) ** 2)  # per-step odometry edge
                                   # covariance when no scan match is available [m^2, m^2, rad^2]
QUERY_RANGE_MARGIN = 1.0  # a scan matches only its hits this much closer than the range threshold,
                          # while its hits up to the threshold serve as reference: otherwise the
                          # far edge of what the reference saw pulls every match backwards
                          # (its farthest hits score only where the reference reaches) [m]
REFERENCE_CACHE_NODES = 1024  # nodes whose map-frame reference is kept (pose_graph.ReferenceCache)
RESUME_COVARIANCE = (1.0, 1.0, math.radians(30.0) ** 2)  # a new session's first node where its
                                   # scan matched nothing: start_at's pose, loosely [m^2, m^2, rad^2]


@dataclass
class LaserGeometry:
    """The laser as the base sees it (beam angles counter-clockwise in the base's orientation;
    an upside-down laser's angles are turned into it by the caller, see laser_mount)."""
    angle_min: float          # first beam [rad]
    angle_increment: float    # between beams [rad]
    n_beams: int              # [-]
    range_min: float          # shorter readings are no return [m]
    range_max: float          # longer readings are no return [m]
    mount: Tuple[float, float, float] = (0.0, 0.0, 0.0)  # laser in the base frame (x [m], y [m], yaw [rad])

    def angles(self) -> np.ndarray:
        return self.angle_min + self.angle_increment * np.arange(int(self.n_beams))


def _p(default, meaning, lo=None, hi=None):
    return field(default=default, metadata=dict(meaning=meaning, lo=lo, hi=hi))


@dataclass
class KartoParams:
    """slam_karto's parameters (ROS names, values as a slam_karto YAML gives them) with open_karto's
    defaults; units in each meaning. The three "variance" ones are not variances: slam_karto
    hands them to open_karto's setters, which square them."""
    map_update_interval: float = _p(5.0, "seconds between map publications [s] (the node's)", 0.0)
    resolution: float = _p(0.05, "map cell size [m] (alias: delta)", 1e-4)
    throttle_scans: int = _p(1, "use every n-th scan [-]", 1)
    minimum_time_interval: float = _p(3600.0, "a scan this long after the last node is taken [s]", 0.0)
    minimum_travel_distance: float = _p(0.2, "odometry travel that makes a node [m]", 0.0)
    minimum_travel_heading: float = _p(math.radians(10.0), "odometry turn that makes a node [rad]", 0.0)
    use_scan_matching: bool = _p(True, "match scans (else odometry only)")
    use_scan_barycenter: bool = _p(True, "distances between nodes from their scans' barycenters")
    scan_buffer_size: int = _p(70, "nodes in the running buffer [-]", 1)
    scan_buffer_maximum_scan_distance: float = _p(20.0, "span of the running buffer [m]", 0.0)
    link_match_minimum_response_fine: float = _p(0.8, "near-chain links need this response [-]", 0.0, 1.0)
    link_scan_maximum_distance: float = _p(10.0, "near chains lie within this [m]", 0.0)
    loop_search_maximum_distance: float = _p(4.0, "loop candidates lie within this [m]", 0.0)
    do_loop_closing: bool = _p(True, "close loops")
    loop_match_minimum_chain_size: int = _p(10, "nodes a loop candidate chain needs [-]", 1)
    loop_match_maximum_variance_coarse: float = _p(0.4, "coarse loop match x / y spread bound [m] (slam_karto "
                                                        "squares it: the variance bound is its square)", 0.0)
    loop_match_minimum_response_coarse: float = _p(0.7, "coarse loop match response needed [-]", 0.0, 1.0)
    loop_match_minimum_response_fine: float = _p(0.7, "fine loop match response needed [-]", 0.0, 1.0)
    correlation_search_space_dimension: float = _p(0.3, "sequential search window side [m]", 1e-3)
    correlation_search_space_resolution: float = _p(0.01, "sequential lookup grid cell [m]", 1e-4)
    correlation_search_space_smear_deviation: float = _p(0.03, "sequential hit smear std [m]", 0.0)
    loop_search_space_dimension: float = _p(8.0, "loop search window side [m]", 1e-3)
    loop_search_space_resolution: float = _p(0.05, "loop lookup grid cell [m]", 1e-4)
    loop_search_space_smear_deviation: float = _p(0.03, "loop hit smear std [m]", 0.0)
    distance_variance_penalty: float = _p(0.3, "offset penalty spread [m] (slam_karto squares it: the penalty's "
                                               "variance is its square)", 1e-9)
    angle_variance_penalty: float = _p(math.radians(20.0), "heading penalty spread [rad] (slam_karto squares it: "
                                                           "the penalty's variance is its square)", 1e-9)
    fine_search_angle_offset: float = _p(math.radians(0.2), "fine heading step [rad]", 1e-6)
    coarse_search_angle_offset: float = _p(math.radians(20.0), "coarse heading window +- [rad]", 0.0)
    coarse_angle_resolution: float = _p(math.radians(2.0), "coarse heading step [rad]", 1e-6)
    minimum_angle_penalty: float = _p(0.9, "smallest heading penalty factor [-]", 0.0, 1.0)
    minimum_distance_penalty: float = _p(0.5, "smallest offset penalty factor [-]", 0.0, 1.0)
    use_response_expansion: bool = _p(False, "widen the heading window when nothing matched")
    range_threshold: float = _p(12.0, "readings beyond this are not matched, and free the map up to it "
                                      "(open_karto's laser RangeThreshold) [m]", 0.0)
    correlation_search_max_recenters: int = _p(0, "times the sequential search window moves onto a best "
                                                  "pose found at its edge (ours; 0: open_karto's fixed window) [-]", 0)
    mixed_pixel_min_offset: float = _p(0.0, "leave mixed pixels out of the map: beams whose range lies this "
                                            "far between their neighbours' and off the lines of both "
                                            "(ours, mixed_pixels; 0: off, as open_karto) [m]", 0.0)
    loop_closure_max_correction: float = _p(3.0, "a loop closure that moves a node farther is "
                                                 "rejected (ours) [m]", 0.0)

    @classmethod
    def from_params(cls, params: Dict) -> Tuple["KartoParams", List[str]]:
        """KartoParams from a dict of ROS parameters: (params, notes). `delta` is an alias of
        `resolution` (as slam_karto reads it when resolution is not set); unknown keys are
        named in notes and ignored. A wrong type or a value out of range raises ValueError
        naming the parameter."""
        params = dict(params)
        notes = []
        if "delta" in params:
            delta = params.pop("delta")
            if "resolution" in params:
                notes.append("both resolution and delta given: delta ignored")
            else:
                params["resolution"] = delta
        known = {f.name: f for f in dataclasses.fields(cls)}
        values = {}
        for key, value in params.items():
            f = known.get(key)
            if f is None:
                notes.append(f"unknown parameter {key!r} ignored")
                continue
            values[key] = _checked(key, value, f)
        return cls(**values), notes

    def validate(self) -> "KartoParams":
        for f in dataclasses.fields(self):
            _checked(f.name, getattr(self, f.name), f)
        return self


def _checked(name, value, f):
    kind = type(f.default)
    if kind is bool:
        if not isinstance(value, (bool, np.bool_)):
            raise ValueError(f"parameter {name} must be a bool, got {value!r}")
        return bool(value)
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise ValueError(f"parameter {name} must be a number, got {value!r}")
    if kind is int:
        if float(value) != int(value):
            raise ValueError(f"parameter {name} must be an integer, got {value!r}")
        value = int(value)
    else:
        value = float(value)
    if not math.isfinite(value):
        raise ValueError(f"parameter {name} must be finite, got {value!r}")
    lo, hi = f.metadata.get("lo"), f.metadata.get("hi")
    if (lo is not None and value < lo) or (hi is not None and value > hi):
        raise ValueError(f"parameter {name} = {value} is out of range [{lo}, {hi}]")
    return value


def loop_covariance(coarse: cm.MatchResult, fine: cm.MatchResult) -> np.ndarray:
    """A loop edge's covariance (3, 3): x-y from the coarse match when its spread is the
    wider (its window spans the whole loop search, the fine one a few centimetres, so only
    the coarse surface shows a corridor's length), the heading from the fine match."""
    cov = fine.covariance.copy()
    fine_xy = np.linalg.eigvalsh(fine.covariance[:2, :2])
    if np.linalg.eigvalsh(coarse.covariance[:2, :2])[-1] > fine_xy[-1]:
        cov[:2, :2] = cm.floor_eigenvalues(coarse.covariance[:2, :2], fine_xy[0])
        cov[:2, 2] = cov[2, :2] = 0.0
    return cov


@dataclass
class ScanResult:
    node_id: int
    pose: Tuple[float, float, float]   # base pose in the map [m, m, rad]
    loop_closed: bool
    response: float                    # sequential match response [0, 1] (0 without matching)


class KartoMapper:
    """Graph SLAM over laser scans (module docstring). Not thread safe: one caller."""

    def __init__(self, params: KartoParams, laser: LaserGeometry):
        self.params = params.validate()
        self.laser = laser
        if int(laser.n_beams) < 2:
            raise ValueError(f"laser needs at least 2 beams, got {laser.n_beams}")
        self._angles = laser.angles()
        self._mount = np.asarray(laser.mount, float)
        p = params
        settings = cm.MatcherSettings(
            coarse_search_angle_offset=p.coarse_search_angle_offset, coarse_angle_resolution=p.coarse_angle_resolution,
            fine_search_angle_offset=p.fine_search_angle_offset, distance_variance_penalty=p.distance_variance_penalty ** 2,
            angle_variance_penalty=p.angle_variance_penalty ** 2, minimum_distance_penalty=p.minimum_distance_penalty,
            minimum_angle_penalty=p.minimum_angle_penalty, use_response_expansion=p.use_response_expansion)
        self._sequential = cm.ScanMatcher(cm.SearchSpace(p.correlation_search_space_dimension,
                                                         p.correlation_search_space_resolution,
                                                         p.correlation_search_space_smear_deviation),
                                          dataclasses.replace(settings,
                                                              max_recenters=p.correlation_search_max_recenters),
                                          p.range_threshold)
        self._loop = cm.ScanMatcher(cm.SearchSpace(p.loop_search_space_dimension, p.loop_search_space_resolution,
                                                   p.loop_search_space_smear_deviation), settings, p.range_threshold)
        self.graph = PoseGraph()
        self._renderer = Renderer()    # the map, cast again only where poses changed
        self._refs = ReferenceCache(REFERENCE_CACHE_NODES)
        self._running: List[int] = []
        self._scan_count = 0
        self._last_odom: Optional[np.ndarray] = None
        self._anchor: Optional[Tuple[np.ndarray, np.ndarray]] = None   # (map pose, odom pose) from start_at
        self.log: List[str] = []       # rejected closures and other notes, newest last
        self.closure_chi2: List[Tuple[float, float, int]] = []  # (chi2 without, with, edges) of each
                                       # closure tried: what check_closure judged, for analysis
        self.stats = dict(nodes=0, loop_closures=0, rejected_loop_closures=0, scans_processed=0,
                          scans_received=0, optimizations=0)

    # ------------------------------------------------------------------ scans
    def add_scan(self, ranges: np.ndarray, odom_pose, stamp: float) -> Optional[ScanResult]:
        """Offer a scan with the odometry pose (x, y, yaw) of the base at its time [m, rad]
        and its stamp [s]. None when throttled or the robot did not move enough; else the
        new node. ValueError (nothing changed) on a wrong beam count or a bad pose."""
        r = np.asarray(ranges, dtype=float).reshape(-1)
        if r.size != int(self.laser.n_beams):
            raise ValueError(f"scan has {r.size} beams, the laser {int(self.laser.n_beams)}")
        odom = np.asarray(odom_pose, float).reshape(-1)
        if odom.size != 3 or not np.all(np.isfinite(odom)) or not math.isfinite(float(stamp)):
            raise ValueError(f"odometry pose {odom_pose!r} / stamp {stamp!r} must be 3 finite numbers and a finite time")
        self.stats["scans_received"] += 1
        self._last_odom = odom
        self._scan_count += 1
        if self._scan_count % self.params.throttle_scans != 0:
            return None
        if not self._moved_enough(odom, float(stamp)):
            return None
        return self._process(r, odom, float(stamp))

    def _moved_enough(self, odom, stamp) -> bool:
        if not self.graph.nodes or self._anchor is not None:
            return True
        last = self.graph.nodes[-1]
        p = self.params
        if stamp - last.stamp >= p.minimum_time_interval:
            return True
        d = between(last.odom_pose, odom)
        return abs(d[2]) >= p.minimum_travel_heading or math.hypot(d[0], d[1]) >= p.minimum_travel_distance

    def _points(self, r: np.ndarray) -> np.ndarray:
        return self._points_and_reference(r)[0]

    def _points_and_reference(self, r: np.ndarray):
        """(hit points to match (k, 2), reference points (m, 2)) in the base frame of ranges
        r (n,): readings within [range_min, min(range_max, range_threshold)], those to
        match QUERY_RANGE_MARGIN closer. float32, the points to match first in the
        reference and `points` a view of them: a node keeps its scan once (a willow-full
        exploration holds 2500 nodes of 1081 beams; float64 copies of both were 90 MB)."""
        lim = min(self.laser.range_max, self.params.range_threshold)
        with np.errstate(invalid="ignore"):
            ok = np.isfinite(r) & (r >= self.laser.range_min) & (r <= lim) & (r > 0.0)
        a = self._angles[ok]
        local = np.column_stack((r[ok] * np.cos(a), r[ok] * np.sin(a)))
        ref_only = np.hypot(local[:, 0], local[:, 1]) > lim - QUERY_RANGE_MARGIN
        pts_all = transform_points(self._mount, local)
        ref = np.concatenate((pts_all[~ref_only], pts_all[ref_only])).astype(np.float32)
        return ref[:int(np.count_nonzero(~ref_only))], ref

    def _process(self, r, odom, stamp) -> ScanResult:
        p = self.params
        pts, ref_pts = self._points_and_reference(r)
        resumed = self._anchor is not None and bool(self.graph.nodes)
        if self._anchor is not None:
            map_pose, odom_at = self._anchor
            predicted = compose(map_pose, between(odom_at, odom))
            self._anchor = None
        elif self.graph.nodes:
            last = self.graph.nodes[-1]
            predicted = compose(last.pose, between(last.odom_pose, odom))
        else:
            predicted = odom.copy()
        response = 0.0
        match = None
        # a new session (start_at) matches against the old nodes around its start
        reference_ids = self._running if not resumed else self._nodes_near(predicted[:2])
        if p.use_scan_matching and reference_ids and len(pts):
            ref = np.vstack([self._refs.get(self.graph.nodes[k]) for k in reference_ids])
            match = self._sequential.match(pts, ref, predicted, penalize=True, refine=True)
            response = match.response
            if response > cm.RESPONSE_TIE:
                predicted = match.pose
        node = Node(id=len(self.graph.nodes), stamp=stamp, odom_pose=odom.copy(), pose=predicted.copy(),
                    ranges=r.astype(np.float32), points=pts, reference=ref_pts,
                    barycenter=pts.mean(axis=0) if len(pts) else np.zeros(2))
        nid = self.graph.add_node(node)
        if resumed:
            self._link_resumed(node, match)
        else:
            self._add_edges(node, match)
        self._add_running(nid)
        closed = False
        if p.use_scan_matching and p.do_loop_closing and len(pts):
            closed = self._try_close_loop(nid)
        self.stats["nodes"] = len(self.graph.nodes)
        self.stats["scans_processed"] += 1
        pose = self.graph.nodes[nid].pose
        return ScanResult(nid, (float(pose[0]), float(pose[1]), float(pose[2])), closed, float(response))

    def _add_edges(self, node: Node, match) -> None:
        g = self.graph
        if node.id == 0:
            return
        prev = g.nodes[node.id - 1]
        if match is not None and match.response > cm.RESPONSE_TIE:
            g.add_edge(prev.id, node.id, "sequential", between(prev.pose, node.pose), covariance=match.covariance)
        else:
            # no match (scan matching off, an empty scan, a new session's first scan):
            # the odometry increment keeps the graph connected
            g.add_edge(prev.id, node.id, "odometry", between(prev.odom_pose, node.odom_pose),
                       covariance=np.diag(ODOMETRY_COVARIANCE))
        if match is None or match.response <= cm.RESPONSE_TIE:
            return
        # the running buffer's closest node (open_karto's LinkChainToScan)
        if self._running:
            k = lc.closest_node(g, self._running, node.pose)
            if k != prev.id:
                g.add_edge(k, node.id, "sequential", between(g.nodes[k].pose, node.pose), covariance=match.covariance)
        links = self._link_near_chains(node)
        if links:
            # the node goes where all its matches agree best (open_karto's AddEdges)
            node.pose = weighted_mean([node.pose] + [m.pose for m in links],
                                      [match.covariance] + [m.covariance for m in links])

    def _nodes_near(self, xy) -> List[int]:
        """Nodes whose base lies within link_scan_maximum_distance of xy [m]."""
        poses = self.graph.poses()
        d = np.hypot(poses[:, 0] - xy[0], poses[:, 1] - xy[1])
        return [int(k) for k in np.nonzero(d <= self.params.link_scan_maximum_distance)[0]]

    def _link_resumed(self, node: Node, match) -> None:
        """Tie a new session's first node to the closest old node: by its match against the
        old nodes around it, else (nothing matched) by the pose start_at gave, loosely."""
        g = self.graph
        old = list(range(node.id))
        k = lc.closest_node(g, old, node.pose)
        if match is not None and match.response > cm.RESPONSE_TIE:
            g.add_edge(k, node.id, "sequential", between(g.nodes[k].pose, node.pose), covariance=match.covariance)
        else:
            g.add_edge(k, node.id, "odometry", between(g.nodes[k].pose, node.pose),
                       covariance=np.diag(RESUME_COVARIANCE))
        self._running = []

    def _link_near_chains(self, node: Node) -> List[cm.MatchResult]:
        """open_karto's LinkNearChains: chains of consecutive nodes within
        link_scan_maximum_distance that the graph already ties to this node's neighbourhood
        and that are not in the running buffer, matched (not penalized). Returns the
        matches that made an edge."""
        p = self.params
        g = self.graph
        positions = g.positions(p.use_scan_barycenter)
        near = lc.near_linked(g, node.id, p.link_scan_maximum_distance, positions)
        running = set(self._running)
        done = set(running) | {node.id}
        within = np.hypot(*(positions - positions[node.id]).T) <= p.link_scan_maximum_distance

        def close(k):
            return within[k]

        linked = []
        for k in sorted(near - done):
            if k in done:
                continue
            chain = [k]
            done.add(k)
            lo = k - 1
            while lo >= 0 and lo not in done and close(lo):
                chain.insert(0, lo)
                done.add(lo)
                lo -= 1
            hi = k + 1
            while hi < node.id and hi not in done and close(hi):
                chain.append(hi)
                done.add(hi)
                hi += 1
            if len(chain) < p.loop_match_minimum_chain_size:
                continue
            ref = np.vstack([self._refs.get(g.nodes[c]) for c in chain])
            m = self._sequential.match(node.points, ref, node.pose, penalize=False, refine=True)
            if m.response >= p.link_match_minimum_response_fine - cm.RESPONSE_TIE:
                c = lc.closest_node(g, chain, m.pose)
                g.add_edge(c, node.id, "sequential", between(g.nodes[c].pose, m.pose), covariance=m.covariance)
                linked.append(m)
        return linked

    def _add_running(self, nid: int) -> None:
        p = self.params
        self._running.append(nid)
        bary = p.use_scan_barycenter
        while len(self._running) > p.scan_buffer_size:
            self._running.pop(0)
        last = self.graph.nodes[nid].position(bary)
        while len(self._running) > 1 and np.hypot(*(self.graph.nodes[self._running[0]].position(bary) - last)) \
                > p.scan_buffer_maximum_scan_distance:
            self._running.pop(0)

    def _try_close_loop(self, nid: int) -> bool:
        p = self.params
        g = self.graph
        node = g.nodes[nid]
        positions = g.positions(p.use_scan_barycenter)
        near = lc.near_linked(g, nid, p.loop_search_maximum_distance, positions)
        start = 0
        closed = False
        while True:
            chain, start = lc.candidate_chain(nid, near, p.loop_search_maximum_distance,
                                              p.loop_match_minimum_chain_size, positions, start)
            if not chain:
                return closed
            ref = np.vstack([self._refs.get(g.nodes[c]) for c in chain])
            coarse = self._loop.match(node.points, ref, node.pose, penalize=False, refine=False,
                                      min_response=p.loop_match_minimum_response_coarse)
            if not (coarse.response >= p.loop_match_minimum_response_coarse
                    and coarse.covariance[0, 0] < p.loop_match_maximum_variance_coarse ** 2
                    and coarse.covariance[1, 1] < p.loop_match_maximum_variance_coarse ** 2):
                continue
            fine = self._sequential.match(node.points, ref, coarse.pose, penalize=False, refine=True)
            if fine.response < p.loop_match_minimum_response_fine:
                continue
            if self._close(chain, nid, dataclasses.replace(fine, covariance=loop_covariance(coarse, fine))):
                closed = True
                positions = g.positions(p.use_scan_barycenter)
                near = lc.near_linked(g, nid, p.loop_search_maximum_distance, positions)

    def _close(self, chain, nid, fine) -> bool:
        g = self.graph
        before = g.poses()
        without = optimize_graph(g)
        g.set_poses(without.poses)
        k = lc.closest_node(g, chain, fine.pose)
        edge = g.add_edge(k, nid, "loop", between(before[k], fine.pose), covariance=fine.covariance)
        start = without.poses.copy()
        start[nid] = fine.pose
        i, j, z, info = g.edge_arrays()
        result = optimize(start, i, j, z, info)
        self.stats["optimizations"] += 2
        self.closure_chi2.append((without.chi2_after, result.chi2_after, len(g.edges)))
        why = lc.check_closure(g, edge, before, result.poses, self.params.loop_closure_max_correction,
                               without.chi2_after, result.chi2_after)
        if why is not None:
            g.remove_edge(edge)
            g.set_poses(before)
            self.stats["rejected_loop_closures"] += 1
            self.log.append(f"loop closure node {k} -> node {nid} rejected: {why}")
            return False
        g.set_poses(result.poses)
        self.stats["loop_closures"] += 1
        return True

    # ---------------------------------------------------------------- queries
    def map_to_odom(self) -> Tuple[float, float, float]:
        """map -> odom (x, y, yaw) [m, rad] implied by the latest node (identity before any)."""
        if self._anchor is not None:
            m, o = self._anchor
            t = compose(m, inverse(o))
        elif not self.graph.nodes:
            return (0.0, 0.0, 0.0)
        else:
            last = self.graph.nodes[-1]
            t = compose(last.pose, inverse(last.odom_pose))
        return (float(t[0]), float(t[1]), float(t[2]))

    def pose(self) -> Tuple[float, float, float]:
        """The base in the map [m, rad] at the latest scan offered: map_to_odom times its odometry."""
        if self._last_odom is None:
            return self.map_to_odom()
        t = compose(np.array(self.map_to_odom()), self._last_odom)
        return (float(t[0]), float(t[1]), float(t[2]))

    def take_log(self) -> List[str]:
        """Notes since the last call (rejected loop closures, with why), oldest first."""
        out, self.log = self.log, []
        return out

    def node_poses(self) -> np.ndarray:
        """Corrected node poses (N, 3) [m, m, rad]."""
        return self.graph.poses()

    def node_stamps(self) -> np.ndarray:
        return np.array([n.stamp for n in self.graph.nodes])

    def edges(self) -> List[Tuple[int, int, str]]:
        return [(e.i, e.j, e.kind) for e in self.graph.edges]

    def occupancy_grid(self, resolution: Optional[float] = None) -> Tuple[np.ndarray, Tuple[float, float]]:
        """(grid int8 (H, W): -1 unknown, 0 free, 100 occupied, row 0 the lowest y; origin
        (x, y) [m] of its lower-left corner) rendered from the corrected poses."""
        res = float(resolution if resolution is not None else self.params.resolution)
        if not res > 0.0:
            raise ValueError(f"resolution must be > 0, got {resolution!r}")
        if not self.graph.nodes:
            return np.full((1, 1), -1, np.int8), (0.0, 0.0)
        def ranges(k0, k1):
            r = np.array([n.ranges for n in self.graph.nodes[k0:k1]], float).reshape(-1, len(self._angles))
            with np.errstate(invalid="ignore"):
                r[~(r >= self.laser.range_min)] = np.nan
            if self.params.mixed_pixel_min_offset <= 0.0:
                return r
            no_hit = np.zeros(r.shape, bool)
            for row, node in zip(no_hit, self.graph.nodes[k0:k1]):
                row[self._mixed(node)] = True          # mixed pixels: their line free, no surface
            return r, no_hit
        return self._renderer.render(self.graph.poses(), ranges, self._angles, self._mount,
                                     self.params.range_threshold, self.laser.range_max, res)

    def _mixed(self, node: Node) -> np.ndarray:
        """The beams of node's scan the map leaves out as mixed pixels (mixed_pixels),
        found once per node: the map is cast anew from every node after a loop closes."""
        key = self.params.mixed_pixel_min_offset
        if node.mixed is None or node.mixed[0] != key:
            node.mixed = (key, np.flatnonzero(mixed_pixel_mask(node.ranges, self._angles, key)).astype(np.int32))
        return node.mixed[1]

    # ------------------------------------------------------------ persistence
    def save(self, path: str) -> None:
        """Write the graph, its scans and the laser geometry to `path` (serialize)."""
        from .serialize import save_mapper
        save_mapper(self, path)

    @classmethod
    def load(cls, path: str, params: Optional[KartoParams] = None) -> "KartoMapper":
        """A mapper from a file written by save(); params replace the saved ones if given.
        ValueError on a corrupt or foreign file."""
        from .serialize import load_mapper
        return load_mapper(cls, path, params)

    def start_at(self, map_pose, odom_pose) -> None:
        """Continue mapping (after load): the next scan becomes a node at map_pose [m, rad]
        as predicted from its odometry relative to odom_pose (where the robot is now)."""
        m = np.asarray(map_pose, float).reshape(-1)
        o = np.asarray(odom_pose, float).reshape(-1)
        if m.size != 3 or o.size != 3 or not (np.all(np.isfinite(m)) and np.all(np.isfinite(o))):
            raise ValueError(f"start_at needs two finite poses (x, y, yaw), got {map_pose!r}, {odom_pose!r}")
        self._anchor = (np.array([m[0], m[1], float(wrap(m[2]))]), o)
        self._running = []
        self._last_odom = o
