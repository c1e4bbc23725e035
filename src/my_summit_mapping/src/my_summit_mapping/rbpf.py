"""Rao-Blackwellized particle filter SLAM in the manner of gmapping.

Reference: Grisetti, Stachniss, Burgard 2007, "Improved Techniques for Grid Mapping with
Rao-Blackwellized Particle Filters", IEEE T-RO 23(1); GMapping's
GridSlamProcessor::processScan (gridfastslam/gridslamprocessor.cpp, .hxx).

Each particle is a robot pose (one row of an (N, 3) array), an accumulated log weight and
its own occupancy grid (grid.PatchGrid, shared copy-on-write). Per laser scan:
  1. move every particle by the odometry change (motion_model.sample_motion);
  2. only if the robot moved linearUpdate [m] or turned angularUpdate [rad] since the
     last processed scan (or temporalUpdate [s] passed), go on:
  3. scan-match each particle against its own map (scan_matcher.optimize) - the improved
     proposal; keep the odometry pose if the score is <= minimumScore;
  4. add the scan's log-likelihood at the new pose to the particle's log weight;
  5. normalize: w_i ~ exp((l_i - l_max) / (ogain * N)); Neff = 1 / sum(w_i^2);
  6. if Neff < resampleThreshold * N: low-variance resampling (maps shared, log weights
     reset to 0);
  7. add the scan's end points to each particle's map at its pose (slam_gmapping runs
     gmapping with generateMap false: no ray tracing in the particles' maps).
The published map (occupancy_grid) ray-traces every processed scan from the best
particle's ancestry, as slam_gmapping's updateMap does.
The best particle is the one with the largest cumulative log-likelihood (gmapping's
weightSum); its map is the published map, its ancestry the trajectory.
"""
import math
from typing import List, Optional, Sequence, Tuple

import numpy as np

from . import motion_model, scan_matcher
from .grid import FILTER_POOL_BYTES, PATCH_BYTES, PatchGrid, PatchPool
from .slam_config import SlamConfig

RANGE_MAX_MARGIN = 0.01  # slam_gmapping's default maxRange = scan range_max - this [m]


def low_variance_resample(weights: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Indices (N,) drawn by low-variance (systematic) resampling of normalized weights (N,).

    One uniform offset, N equally spaced pointers into the cumulative weights (gmapping's
    uniform_resampler; Probabilistic Robotics table 4.4): particle i is copied
    floor(N*w_i) or ceil(N*w_i) times. The indices come out sorted.
    """
    w = np.asarray(weights, float)
    n = len(w)
    cumulative = np.cumsum(w)
    cumulative /= cumulative[-1]
    pointers = (rng.random() + np.arange(n)) / n
    return np.minimum(np.searchsorted(cumulative, pointers, side="right"), n - 1)


def normalized_weights(log_weights: np.ndarray, ogain: float) -> Tuple[np.ndarray, float]:
    """gmapping's normalize(): (weights (N,) summing to 1, Neff)."""
    gain = 1.0 / (ogain * len(log_weights))
    w = np.exp(gain * (log_weights - log_weights.max()))
    w /= w.sum()
    return w, 1.0 / float(np.sum(w * w))


def warm_up() -> None:
    """Run every compiled kernel once on a tiny case, so that a node loads the kernels'
    library (summit_nav_common.native) before its first scan, and fails at its start,
    not at that scan, when the library is missing."""
    angles = np.linspace(-1.5, 1.5, 8)
    slam = RbpfSlam(SlamConfig(particles=2, xmin=-1.0, ymin=-1.0, xmax=1.0, ymax=1.0),
                    np.random.default_rng(0))
    for k in range(3):
        slam.process((0.6 * k, 0.0, 0.0), np.full(angles.shape, 2.0), angles, timestamp=float(k))
    slam.occupancy_grid()


class RbpfSlam:
    """gmapping-style RBPF SLAM core.

    config: SlamConfig (gmapping's parameters); rng: numpy Generator for motion noise and
    resampling (pass a seeded one for repeatable runs). Feed scans with `process`.
    """

    def __init__(self, config: SlamConfig, rng: np.random.Generator):
        config.validate()
        self.config = config
        self.rng = rng
        n = config.particles
        self.poses = np.zeros((n, 3))                 # particle base poses [m, m, rad]
        self.log_weights = np.zeros(n)                # log-lik since the last resampling
        self.log_weight_sums = np.zeros(n)            # log-lik of the whole lineage
        self.weights = np.full(n, 1.0 / n)            # normalized weights [-]
        self.neff = float(n)                          # effective sample size [-]
        self.maps: List[PatchGrid] = []
        self.update_count = 0                         # processed scans
        self.resample_count = 0
        self._n_beams: Optional[int] = None
        self._last_odom: Optional[np.ndarray] = None
        self._last_update_time: Optional[float] = None
        self._linear_distance = 0.0                   # since the last processed scan [m]
        self._angular_distance = 0.0                  # since the last processed scan [rad]
        self._hist_poses: List[np.ndarray] = []       # per processed scan: poses before resampling
        self._hist_parents: List[np.ndarray] = []     # per processed scan: resampling indices
        self._hist_times: List[float] = []
        self._hist_scans: List[tuple] = []           # per processed scan: (ranges, angles, laser, maxRange)
        self._render_base: Optional[PatchGrid] = None  # ray-traced map of the particles' common past
        self._render_upto = -1                        # ... up to this processed scan

    # ------------------------------------------------------------------ input
    def process(self, odom_pose: Sequence[float], ranges: Sequence[float],
                angles: Sequence[float], laser_pose_in_base: Sequence[float] = (0.0, 0.0, 0.0),
                timestamp: Optional[float] = None, range_max: Optional[float] = None) -> bool:
        """Feed one laser scan with the odometry pose at its time.

        odom_pose: (x [m], y [m], theta [rad]) of the base in the odom frame.
        ranges: (n,) [m]; NaN, inf and values >= maxRange mean "no return" (free space up
        to maxUrange), values <= 0 are ignored. angles: (n,) [rad] in the laser frame.
        laser_pose_in_base: (x [m], y [m], yaw [rad]) of the laser in the base frame.
        timestamp: scan time [s], needed for temporalUpdate. range_max: the sensor's
        range_max [m], used when config.maxRange is None.
        Returns True when the scan was used (filter updated), False when it only moved
        the particles. Raises ValueError on malformed input or a changed beam count.
        """
        odom = np.asarray(odom_pose, float).reshape(-1)
        r = np.asarray(ranges, float).reshape(-1)
        a = np.asarray(angles, float).reshape(-1)
        laser = np.asarray(laser_pose_in_base, float).reshape(-1)
        self._check_input(odom, r, a, laser)
        max_range = self._max_range(range_max)
        if self._last_odom is None:
            self._initialize(odom, r, a, laser, max_range, timestamp)
            return True
        self._predict(odom)
        if not self._should_update(timestamp):
            return False
        self._update(r, a, laser, max_range, timestamp)
        return True

    def _check_input(self, odom, r, a, laser):
        if odom.shape != (3,) or not np.all(np.isfinite(odom)):
            raise ValueError(f"odom_pose must be 3 finite numbers (x, y, theta), got {odom!r}")
        if laser.shape != (3,) or not np.all(np.isfinite(laser)):
            raise ValueError(f"laser_pose_in_base must be 3 finite numbers, got {laser!r}")
        if r.shape != a.shape:
            raise ValueError(f"ranges ({r.size}) and angles ({a.size}) differ in length")
        if r.size == 0:
            raise ValueError("empty scan")
        if not np.all(np.isfinite(a)):
            raise ValueError("beam angles must be finite")
        if self._n_beams is None:
            self._n_beams = r.size
        elif r.size != self._n_beams:
            raise ValueError(f"beam count changed from {self._n_beams} to {r.size}: the filter "
                             f"keeps one laser configuration (restart it for another laser)")

    def _max_range(self, range_max):
        if self.config.maxRange is not None:
            return self.config.maxRange
        if range_max is not None and math.isfinite(range_max):
            return float(range_max) - RANGE_MAX_MARGIN
        return math.inf

    # ------------------------------------------------------------- the steps
    def _initialize(self, odom, r, a, laser, max_range, timestamp):
        """First scan: all particles at the odometry pose, sharing the scan's map."""
        self.poses[:] = odom
        first = PatchGrid(self.config.delta, PatchPool(FILTER_POOL_BYTES // PATCH_BYTES))
        lp = scan_matcher.laser_poses(odom[None, :], laser)[0]
        first.add_hits(lp, r, a, self.config.maxUrange, max_range)
        self.maps = [first] + [first.copy() for _ in range(self.config.particles - 1)]
        self._last_odom = odom
        self._last_update_time = timestamp
        self._record(np.arange(self.config.particles), timestamp, (r, a, laser, max_range))
        self.update_count = 1

    def _predict(self, odom):
        """Step 1: sample the motion of every particle; accumulate the travelled distance."""
        c = self.config
        motion_model.sample_motion(self.poses, self._last_odom, odom, c.srr, c.srt, c.str,
                                   c.stt, self.rng, out=self.poses)
        inc = motion_model.odometry_increment(self._last_odom, odom)
        self._linear_distance += math.hypot(inc[0], inc[1])
        self._angular_distance += abs(inc[2])
        self._last_odom = odom

    def _should_update(self, timestamp) -> bool:
        """Step 2: gmapping's linearUpdate / angularUpdate / temporalUpdate gate."""
        c = self.config
        if self._linear_distance >= c.linearUpdate or self._angular_distance >= c.angularUpdate:
            return True
        return (c.temporalUpdate >= 0.0 and timestamp is not None
                and self._last_update_time is not None
                and timestamp - self._last_update_time > c.temporalUpdate)

    def _update(self, r, a, laser, max_range, timestamp):
        c = self.config
        beams = scan_matcher.select_beams(r, a, c.maxUrange, max_range, c.lskip)
        self._scan_match(beams, laser)                       # steps 3, 4
        self.weights, self.neff = normalized_weights(self.log_weights, c.ogain)  # step 5
        parents = np.arange(c.particles)
        resample = self.neff < c.resampleThreshold * c.particles   # step 6
        if resample:
            parents = low_variance_resample(self.weights, self.rng)
        self._record(parents, timestamp, (r, a, laser, max_range))   # poses before resampling + who survives
        if resample:
            self._resample(parents)
        self._integrate(r, a, laser, max_range, parents)     # step 7
        self._linear_distance = 0.0
        self._angular_distance = 0.0
        self._last_update_time = timestamp
        self.update_count += 1

    def _scan_match(self, beams, laser):
        """Steps 3-4: improve each particle's pose by scan matching, weight it (gmapping's
        GridSlamProcessor::scanMatch): the matched pose is taken when its score is above
        minimumScore; the log-likelihood at the pose taken is added to the weights."""
        c = self.config
        tables = scan_matcher.map_tables(self.maps)
        matched, scores = scan_matcher.optimize(tables, self.poses, laser, beams, c.sigma, c.kernelSize,
                                                c.lstep, c.astep, c.iterations)
        good = scores > c.minimumScore
        self.poses[good] = matched[good]
        loglik, _ = scan_matcher.likelihood_and_score(tables, self.poses, laser, beams, c.sigma, c.lsigma,
                                                      c.kernelSize)
        self.log_weights += loglik
        self.log_weight_sums += loglik

    def _resample(self, parents):
        """Step 6: copy the chosen particles; maps are shared copy-on-write."""
        self.poses = self.poses[parents].copy()
        self.log_weight_sums = self.log_weight_sums[parents].copy()
        self.log_weights = np.zeros(self.config.particles)
        self.weights = np.full(self.config.particles, 1.0 / self.config.particles)
        self.maps = [self.maps[p] for p in parents]  # duplicates: same object, split in _integrate
        self.resample_count += 1

    def _integrate(self, r, a, laser, max_range, parents):
        """Step 7: add the scan's hit points to every particle's map (slam_gmapping runs
        gmapping with generateMap false: the particles' maps hold end points only; the
        published map is ray-traced separately, occupancy_grid).

        Children of one parent have the same pose and map right after resampling, so
        the scan is added once per parent and the children share the result.
        """
        c = self.config
        lps = scan_matcher.laser_poses(self.poses, laser)
        done = {}
        for i, p in enumerate(parents):
            if p in done:
                self.maps[i] = done[p].copy()
                continue
            grid = self.maps[i]
            grid.add_hits(lps[i], r, a, c.maxUrange, max_range)
            done[p] = grid

    def _record(self, parents, timestamp, scan):
        self._hist_poses.append(self.poses.copy())
        self._hist_parents.append(np.asarray(parents).copy())
        self._hist_times.append(np.nan if timestamp is None else float(timestamp))
        r, a, laser, max_range = scan
        self._hist_scans.append((r.copy(), a.copy(), laser.copy(), max_range))

    # ---------------------------------------------------------------- output
    def best_particle(self) -> int:
        """Index of the particle with the largest cumulative log-likelihood."""
        return int(np.argmax(self.log_weight_sums))

    def best_pose(self) -> Optional[np.ndarray]:
        """Pose (3,) [m, m, rad] of the best particle in the map frame; None before any scan."""
        if self._last_odom is None:
            return None
        return self.poses[self.best_particle()].copy()

    def map_to_odom(self) -> Optional[np.ndarray]:
        """The map->odom transform (x [m], y [m], yaw [rad]) = best pose * odom^-1."""
        best = self.best_pose()
        if best is None:
            return None
        odom = self._last_odom
        yaw = best[2] - odom[2]
        c, s = math.cos(yaw), math.sin(yaw)
        return np.array([best[0] - (c * odom[0] - s * odom[1]),
                         best[1] - (s * odom[0] + c * odom[1]),
                         math.atan2(math.sin(yaw), math.cos(yaw))])

    def trajectory(self) -> np.ndarray:
        """Poses (K, 3) [m, m, rad] of the best particle's ancestry at the K processed scans."""
        return self._ancestry(self.best_particle())

    def trajectory_times(self) -> np.ndarray:
        """Timestamps (K,) [s] of the processed scans (NaN where none was given)."""
        return np.array(self._hist_times)

    def _ancestry(self, index: int) -> np.ndarray:
        rows = self._lineage(index)
        return np.array([self._hist_poses[k][i] for k, i in enumerate(rows)]).reshape(-1, 3)

    def _lineage(self, index: int) -> np.ndarray:
        """Row (K,) of each processed scan's recorded poses on particle index's ancestry."""
        rows = np.empty(len(self._hist_poses), np.intp)
        i = index
        for k in range(len(self._hist_poses) - 1, -1, -1):
            i = int(self._hist_parents[k][i])
            rows[k] = i
        return rows

    def _common_past(self) -> int:
        """The last processed scan whose pose all particles' ancestries share (-1: none)."""
        rows = np.arange(self.config.particles)
        for k in range(len(self._hist_poses) - 1, -1, -1):
            rows = self._hist_parents[k][rows]
            if np.all(rows == rows[0]):
                return k
        return -1

    def _trace_history(self, grid: PatchGrid, k: int, row: int) -> None:
        r, a, laser, max_range = self._hist_scans[k]
        lp = scan_matcher.laser_poses(self._hist_poses[k][row][None, :], laser)[0]
        grid.integrate_scan(lp, r, a, self.config.maxUrange, max_range)

    def best_map(self) -> Optional[PatchGrid]:
        """The map slam_gmapping publishes: every processed scan ray-traced (free cells,
        hits) from the best particle's ancestry (gmapping's updateMap, generateMap true).

        The part of the past that all particles share cannot change any more; it is
        traced once and kept (_render_base), only the best lineage's own recent scans
        are traced on a copy of it each time."""
        if not self._hist_poses:
            return None
        rows = self._lineage(self.best_particle())
        if self._render_base is None:
            self._render_base = PatchGrid(self.config.delta, PatchPool())
        for k in range(self._render_upto + 1, self._common_past() + 1):
            self._trace_history(self._render_base, k, rows[k])
            self._render_upto = k
        grid = self._render_base.copy()
        for k in range(self._render_upto + 1, len(rows)):
            self._trace_history(grid, k, rows[k])
        return grid

    def occupancy_grid(self):
        """The best particle's map (best_map) as ROS OccupancyGrid content.

        Returns (data int8 (height*width,) row-major from the lower-left cell, width,
        height, resolution [m], origin_x [m], origin_y [m]); -1 unknown, 0 free, 100
        occupied (occupancy > occ_thresh). Covers at least xmin..xmax, ymin..ymax and
        grows with the explored area. None before any scan.
        """
        grid = self.best_map()
        if grid is None:
            return None
        c = self.config
        return grid.occupancy_grid(c.occ_thresh, extent=(c.xmin, c.ymin, c.xmax, c.ymax))

    def entropy(self) -> float:
        """Entropy [nat] of the normalized particle weights (published on ~entropy)."""
        w = self.weights[self.weights > 0.0]
        return float(-np.sum(w * np.log(w)))

    def map_memory_bytes(self) -> int:
        """Bytes of map patch memory held by all particles together (shared counted once)."""
        seen = set()
        for grid in self.maps:
            seen.update(grid.patch_ids())
        return len(seen) * PATCH_BYTES
