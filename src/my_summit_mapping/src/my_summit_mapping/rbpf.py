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
     proposal; keep the odometry pose if the score is <= minimumScore or the correction
     is implausible under the motion model (plausible_corrections). A beam is matched
     only to obstacle cells it can reach through known free space (DIRECTIONAL_MATCH);
  4. add the scan's log-likelihood at the new pose to the particle's log weight;
  5. normalize: w_i ~ exp((l_i - l_max) / (ogain * N)); Neff = 1 / sum(w_i^2);
  6. if Neff < resampleThreshold * N: low-variance resampling (maps shared, log weights
     reset to 0);
  7. ray-trace the scan into each particle's map at its pose.
The best particle is the one with the largest cumulative log-likelihood (gmapping's
weightSum); its map is the published map, its ancestry the trajectory.
"""
import math
from typing import List, Optional, Sequence, Tuple

import numpy as np

from . import motion_model, scan_matcher
from .grid import PATCH_BYTES, PatchGrid
from .slam_config import SlamConfig

RANGE_MAX_MARGIN = 0.01  # slam_gmapping's default maxRange = scan range_max - this [m]
MATCH_GATE_SIGMAS = 5.0  # a scan-match correction beyond this many motion-model stds is rejected [-]
MATCH_CHUNK_CELLS = 4_000_000  # field cells matched at once (8 per window cell when directional);
                               # 8 bytes each -> <= 32 MB of fields [cells]
DIRECTIONAL_MATCH = True       # match a beam only to obstacle cells it reaches through known free space
                               # (scan_matcher.facing_masks; False: gmapping's plain endpoint fields)


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


def plausible_corrections(predicted: np.ndarray, matched: np.ndarray, std: np.ndarray,
                          min_gate: Tuple[float, float]) -> np.ndarray:
    """(n,) bool: is each scan-matched pose (n, 3) within MATCH_GATE_SIGMAS motion-model
    stds of the particle's predicted pose (n, 3)?

    The improved proposal is p(z | m, x) p(x | x', u) (Grisetti et al. 2007, sec. IV):
    the scan match's mode is a good proposal only where the motion model allows it. In a
    corridor whose end is out of range the score is flat along it, and the hill climbing
    can walk 20 cm on noise in one update, 18 stds of the Summit's odometry (a live tour
    whose SLAM node, busy, used every few scans only: ATE 0.073 m with this drift, 0.005
    m without). Such a correction is refused and the particle keeps its odometry sample, as
    gmapping does for a score below minimumScore.

    std (3,): the motion model's std [m, m, rad] of the odometry increment since the last
    processed scan (motion_model.noise_std), per axis of the predicted pose's frame.
    min_gate: (lstep [m], astep [rad]): a correction within the matcher's first step is
    always allowed (the gate never shrinks below what one hill-climbing move does).
    """
    gate = np.maximum(MATCH_GATE_SIGMAS * np.asarray(std, float),
                      [min_gate[0], min_gate[0], min_gate[1]])
    d = matched - predicted
    cos, sin = np.cos(predicted[:, 2]), np.sin(predicted[:, 2])
    local = np.column_stack((cos * d[:, 0] + sin * d[:, 1], -sin * d[:, 0] + cos * d[:, 1],
                             np.arctan2(np.sin(d[:, 2]), np.cos(d[:, 2]))))
    return np.all(np.abs(local) <= gate, axis=1)


def normalized_weights(log_weights: np.ndarray, ogain: float) -> Tuple[np.ndarray, float]:
    """gmapping's normalize(): (weights (N,) summing to 1, Neff)."""
    gain = 1.0 / (ogain * len(log_weights))
    w = np.exp(gain * (log_weights - log_weights.max()))
    w /= w.sum()
    return w, 1.0 / float(np.sum(w * w))


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
        self._update_odom: Optional[np.ndarray] = None  # odometry pose at the last processed scan
        self._linear_distance = 0.0                   # since the last processed scan [m]
        self._angular_distance = 0.0                  # since the last processed scan [rad]
        self._hist_poses: List[np.ndarray] = []       # per processed scan: poses before resampling
        self._hist_parents: List[np.ndarray] = []     # per processed scan: resampling indices
        self._hist_times: List[float] = []

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
        first = PatchGrid(self.config.delta)
        lp = scan_matcher.laser_poses(odom[None, :], laser)[0]
        first.integrate_scan(lp, r, a, self.config.maxUrange, max_range)
        self.maps = [first] + [first.copy() for _ in range(self.config.particles - 1)]
        self._last_odom = odom
        self._update_odom = odom
        self._last_update_time = timestamp
        self._record(np.arange(self.config.particles), timestamp)
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
        self._record(parents, timestamp)   # poses before resampling + who survives
        if resample:
            self._resample(parents)
        self._integrate(r, a, laser, max_range, parents)     # step 7
        self._linear_distance = 0.0
        self._angular_distance = 0.0
        self._last_update_time = timestamp
        self._update_odom = self._last_odom
        self.update_count += 1

    def _scan_match(self, beams, laser):
        """Steps 3-4: improve each particle's pose by scan matching, weight it.

        Particles are matched in lockstep in chunks whose field windows hold at most
        MATCH_CHUNK_CELLS cells, which bounds the fields' memory.
        """
        c = self.config
        start = scan_matcher.endpoints(self.poses, laser, beams.local_xy)  # (N, K, 2)
        octants = (scan_matcher.beam_octants(self.poses, laser, beams.angles)
                   if DIRECTIONAL_MATCH else None)   # (N, K), fixed for this update
        for chunk in self._match_chunks(start):
            fields = scan_matcher.build_fields([self.maps[i] for i in chunk], start[chunk],
                                               c.sigma, c.lsigma, c.kernelSize,
                                               directional=DIRECTIONAL_MATCH)
            octs = None if octants is None else octants[chunk]
            matched, scores = scan_matcher.optimize(fields, self.poses[chunk], laser, beams,
                                                    c.lstep, c.astep, c.iterations, octs)
            good = (scores > c.minimumScore) & self._plausible(self.poses[chunk], matched)
            self.poses[chunk[good]] = matched[good]
            loglik, _ = scan_matcher.likelihood_and_score(fields, self.poses[chunk], laser, beams, octs)
            self.log_weights[chunk] += loglik
            self.log_weight_sums[chunk] += loglik

    def _plausible(self, predicted, matched):
        """(n,) bool: may each particle take its scan-matched pose (plausible_corrections)?"""
        c = self.config
        inc = motion_model.odometry_increment(self._update_odom, self._last_odom)
        std = motion_model.noise_std(inc, c.srr, c.srt, c.str, c.stt)
        return plausible_corrections(predicted, matched, std, (c.lstep, c.astep))

    def _match_chunks(self, start):
        """Split particle indices into chunks of at most MATCH_CHUNK_CELLS window cells."""
        chunks, current, cells = [], [], 0
        for i in range(self.config.particles):
            _, _, width, height = scan_matcher.field_window(start[i], self.config.delta)
            size = width * height * (scan_matcher.OCTANTS if DIRECTIONAL_MATCH else 1)
            if current and cells + size > MATCH_CHUNK_CELLS:
                chunks.append(np.array(current))
                current, cells = [], 0
            current.append(i)
            cells += size
        chunks.append(np.array(current))
        return chunks

    def _resample(self, parents):
        """Step 6: copy the chosen particles; maps are shared copy-on-write."""
        self.poses = self.poses[parents].copy()
        self.log_weight_sums = self.log_weight_sums[parents].copy()
        self.log_weights = np.zeros(self.config.particles)
        self.weights = np.full(self.config.particles, 1.0 / self.config.particles)
        self.maps = [self.maps[p] for p in parents]  # duplicates: same object, split in _integrate
        self.resample_count += 1

    def _integrate(self, r, a, laser, max_range, parents):
        """Step 7: ray-trace the scan into every particle's map.

        Children of one parent have the same pose and map right after resampling, so
        the scan is traced once per parent and the children share the result.
        """
        c = self.config
        lps = scan_matcher.laser_poses(self.poses, laser)
        done = {}
        for i, p in enumerate(parents):
            if p in done:
                self.maps[i] = done[p].copy()
                continue
            grid = self.maps[i]
            grid.integrate_scan(lps[i], r, a, c.maxUrange, max_range)
            done[p] = grid

    def _record(self, parents, timestamp):
        self._hist_poses.append(self.poses.copy())
        self._hist_parents.append(np.asarray(parents).copy())
        self._hist_times.append(np.nan if timestamp is None else float(timestamp))

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
        out = np.empty((len(self._hist_poses), 3))
        i = index
        for k in range(len(self._hist_poses) - 1, -1, -1):
            i = int(self._hist_parents[k][i])
            out[k] = self._hist_poses[k][i]
        return out

    def occupancy_grid(self):
        """The best particle's map as ROS OccupancyGrid content.

        Returns (data int8 (height*width,) row-major from the lower-left cell, width,
        height, resolution [m], origin_x [m], origin_y [m]); -1 unknown, 0 free, 100
        occupied (occupancy > occ_thresh). Covers at least xmin..xmax, ymin..ymax and
        grows with the explored area. None before any scan.
        """
        if not self.maps:
            return None
        c = self.config
        return self.maps[self.best_particle()].occupancy_grid(
            c.occ_thresh, extent=(c.xmin, c.ymin, c.xmax, c.ymax))

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
