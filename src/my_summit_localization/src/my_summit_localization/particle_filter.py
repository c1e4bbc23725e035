"""Adaptive Monte Carlo Localization: KLD-sampling augmented MCL, as ROS amcl runs it.

Algorithms:
- MCL (Thrun, Burgard, Fox, Probabilistic Robotics, ch. 8.3, table 8.2) with the
  sample motion model (motion_model.py) and a laser model (likelihood_field.py).
- Augmented MCL (Probabilistic Robotics table 8.3): running averages w_slow / w_fast of
  the scan likelihood (decay rates recovery_alpha_slow / recovery_alpha_fast); on each
  resampling a particle is replaced by a uniformly random free-space pose with
  probability max(0, 1 - w_fast / w_slow).
- Sensor resetting (Lenser & Veloso 2000, "Sensor Resetting Localization for Poorly
  Modelled Mobile Robots", ICRA): the fixed threshold that augmented MCL's w_slow
  replaced, kept as a floor under w_slow (recovery_likelihood_threshold, 0 = off; only
  while recovery is on, and only after a global initialization, until the next given
  pose): the probability is max(0, 1 - w_fast / max(w_slow, threshold)). w_slow learns
  what a localized robot scores only from a history; after global localization it starts
  from the spread cloud's low likelihood, against which a wrong but plausible place looks
  fine. A pose given by /initialpose is trusted as amcl trusts it (its averages restart,
  so nothing is injected until they part).
- recovery_global_only (ours; amcl injects whenever recovery is on): random particles
  only from global_localization() until the set has converged with w_fast at or above
  that threshold. Augmented MCL reads any drop of the scan likelihood as being lost, and
  an obstacle the map lacks is such a drop; a random particle in a look-alike place then
  explains it better than the true pose.
- KLD-sampling (Fox 2003, "Adapting the Sample Size in Particle Filters Through
  KLD-Sampling", IJRR 22(12)): the new set grows until its size n exceeds
  ``(k-1)/(2 kld_err) * (1 - 2/(9(k-1)) + sqrt(2/(9(k-1))) * kld_z)^3`` (clamped to
  [min_particles, max_particles]; max_particles while k <= 1), k the number of
  histogram bins (0.5 m x 0.5 m x 10 deg, amcl's pf kd-tree bins) the new set occupies.
  As in amcl, kld_z is used directly as the normal quantile z.
- Low-variance (systematic) resampling (Probabilistic Robotics table 4.4). amcl itself
  draws multinomially one sample at a time because that is how KLD's stopping rule is
  easiest written. Here all max_particles candidates are drawn at once by the
  low-variance sampler, put in random order, and the KLD rule is evaluated on every
  prefix at once (cumulative count of distinct bins); the new set is the shortest
  prefix that satisfies it. Each particle's expected number of copies stays n * w_i.
- Pose estimate as amcl: the particles are clustered (histogram bins joined with their
  26 neighbours, connected components; amcl's pf_kdtree_cluster), the estimate is the
  weighted mean of the heaviest cluster (yaw by circular mean), and the covariance
  amcl publishes is the whole set's: linear part E[x x^T] - mu mu^T, yaw variance
  -2 ln |E[(cos, sin)]| (amcl's circular statistic), no cross terms with yaw.

Update gating and bookkeeping follow amcl_node.cpp laserReceived: the first scan after
(re)initialisation is always used (no motion); later a scan is used when the odometry
moved more than update_min_d along x or along y (odom frame, per axis) or more than
update_min_a in yaw since the last update, or when request_nomotion_update was called
(update_due asks the same without touching the filter, so a node can skip a scan unread).
Each used scan applies the motion model once for the whole odometry increment, then the
laser model, and every resample_interval-th used scan resamples.

Deliberate differences from amcl (documented so nobody hunts for them):
- weights are not reset to 1/N by the motion model (amcl's quirk loses every other
  scan's evidence with resample_interval 2);
- w_slow / w_fast average the scan's *per-beam* likelihood (the laser model's
  per_beam_likelihood: mean pz^3 for amcl's 1 + sum pz^3, geometric mean pz for the
  product model) instead of amcl's raw mean weight, so scans with more or fewer usable
  beams, or the product model's 1e-100 dynamic range, do not look like a lost robot;
- after an injection w_slow / w_fast are kept (Probabilistic Robotics), not reset to 0
  as amcl does (``reset_recovery_on_injection=True`` restores amcl's behaviour): with
  the reset, injection stops after one burst and a kidnapped robot is rarely found;
- the estimate (and map->odom) comes from the set after every used scan (weighted,
  computed lazily when asked), not only after a resampling;
- cluster yaw variance is normalised by the cluster weight (amcl's is not);
- yaw is kept wrapped to [-pi, pi) and the yaw bins wrap around.

Units: poses (x [m], y [m], yaw [rad]) in the map frame; odometry poses in the odom
frame. Particles are an (N, 3) float64 array, weights (N,) summing to 1; both live in
preallocated max_particles buffers (two particle sets, swapped on resampling).
"""
import math
from dataclasses import dataclass

import numpy as np
from summit_nav_common.geometry import compose, inverse

from . import motion_model
from .likelihood_field import FREE, converged, make_laser_model, prepare_ranges, scan_limits, select_beams

# amcl's pf kd-tree histogram bin sizes (pf_kdtree.c: size = {0.50, 0.50, 10 deg}).
BIN_XY = 0.5                      # [m]
BIN_YAW = math.radians(10.0)      # [rad]
N_YAW_BINS = 36                   # 360 deg / 10 deg: yaw bins wrap around
_KEY_OFFSET = 1 << 20             # shifts bin indices >= 0 for key packing [bins]
_KEY_SPAN = 1 << 21               # range of a packed x or y bin index [bins]
# amcl's pf dist_threshold: the filter counts as converged when every particle is within
# this distance of the mean along x and along y [m].
CONVERGED_DIST = 0.5


# -- KLD-sampling ---------------------------------------------------------------------
def kld_limit(k, kld_err, kld_z, min_particles, max_particles):
    """Particles needed for k occupied bins (Fox 2003; amcl's pf_resample_limit).

    k: int or int array of occupied bins. Returns int (or int array) in
    [min_particles, max_particles]; max_particles where k <= 1.
    """
    k = np.asarray(k, dtype=np.float64)
    km1 = np.maximum(k - 1.0, 1.0)
    b = 2.0 / (9.0 * km1)
    x = 1.0 - b + np.sqrt(b) * kld_z
    n = np.ceil(km1 / (2.0 * kld_err) * x ** 3)
    n = np.clip(n, min_particles, max_particles)
    n = np.where(k <= 1, max_particles, n).astype(np.int64)
    return int(n) if n.ndim == 0 else n


# -- resampling -----------------------------------------------------------------------
def low_variance_indices(weights, n, rng, out=None):
    """Low-variance (systematic) resampling: n indices drawn from normalised weights.

    One uniform offset r in [0, 1/n); index i is taken for every u = r + m/n in its
    slice of the cumulative sum (Probabilistic Robotics table 4.4). Each index appears
    floor(n w_i) or ceil(n w_i) times. Returns (n,) int64, ascending.
    """
    cum = np.cumsum(weights)
    cum /= cum[-1]
    u = (rng.random() + np.arange(n)) / n
    idx = np.searchsorted(cum, u, side="right")
    np.minimum(idx, len(weights) - 1, out=idx)  # guards u at the rounding edge of 1.0
    if out is not None:
        out[:] = idx
        return out
    return idx


# -- histogram bins and clusters ------------------------------------------------------
def histogram_keys(particles):
    """Packed int64 key of each particle's (0.5 m, 0.5 m, 10 deg) histogram bin."""
    ix, iy, ia = bin_indices(particles)
    return ((ix + _KEY_OFFSET) * _KEY_SPAN + (iy + _KEY_OFFSET)) * N_YAW_BINS + ia


def particle_clusters(particles):
    """Cluster label (N,) of each particle, 0..C-1, numbered in the order of each
    cluster's first bin (the smallest (ix, iy, iyaw))."""
    labels = cluster_labels(histogram_keys(particles))
    # compact to 0..C-1
    _, labels = np.unique(labels, return_inverse=True)
    return labels


def bin_indices(particles):
    """Histogram bin indices (ix, iy, ia) (three (N,) int64 arrays) of each particle."""
    ix = np.floor(particles[:, 0] / BIN_XY).astype(np.int64)
    iy = np.floor(particles[:, 1] / BIN_XY).astype(np.int64)
    ia = np.floor((motion_model.wrap_angle(particles[:, 2]) + math.pi) / BIN_YAW).astype(np.int64)
    np.clip(ia, 0, N_YAW_BINS - 1, out=ia)
    return ix, iy, ia


def cluster_labels(keys):
    """Cluster label (N,) of each particle from its packed bin key: connected components
    of occupied bins, adjacent when they differ by at most one in each index (yaw wraps).
    A cluster's label is the index of its smallest key among the sorted distinct keys.
    Sorted keys + searchsorted for the neighbours, so any spread of particles works."""
    uniq, inv = np.unique(keys, return_inverse=True)
    ia = uniq % N_YAW_BINS
    rest = uniq // N_YAW_BINS
    iy, ix = rest % _KEY_SPAN, rest // _KEY_SPAN
    rows, cols = [], []
    k = uniq.size
    # Half of the 26 neighbour offsets suffice for an undirected graph.
    offsets = [(dx, dy, da) for dx in (-1, 0, 1) for dy in (-1, 0, 1) for da in (-1, 0, 1)
               if (dx, dy, da) > (0, 0, 0)]
    for dx, dy, da in offsets:
        nk = ((ix + dx) * _KEY_SPAN + (iy + dy)) * N_YAW_BINS + (ia + da) % N_YAW_BINS
        pos = np.minimum(np.searchsorted(uniq, nk), k - 1)
        hit = uniq[pos] == nk
        rows.append(np.nonzero(hit)[0])
        cols.append(pos[hit])
    return connected_components(k, np.concatenate(rows), np.concatenate(cols))[inv]


def connected_components(n, a, b):
    """Component label (n,) of each of n nodes joined by the undirected edges (a[i],
    b[i]): the smallest node index of its component.

    Hooking and pointer jumping (Shiloach & Vishkin 1982), vectorized: every edge hooks
    the larger of its two roots onto the smaller, then every node jumps to its root;
    repeated until no edge joins two roots. A root only ever points lower, so the
    smallest node of a component stays its root.
    """
    label = np.arange(n)
    while True:
        la, lb = label[a], label[b]
        low = np.minimum(la, lb)
        hooked = label.copy()
        np.minimum.at(hooked, la, low)
        np.minimum.at(hooked, lb, low)
        while True:
            jumped = hooked[hooked]
            if np.array_equal(jumped, hooked):
                break
            hooked = jumped
        if np.array_equal(hooked, label):
            return label
        label = hooked


def weighted_pose_stats(particles, weights):
    """amcl's pf_cluster_stats for one set: (mean (3,), cov (3, 3)).

    Linear part: weighted E[x x^T] - mu mu^T; yaw: circular mean and variance
    -2 ln R, R the length of the weighted mean of (cos, sin). No cross terms with yaw.
    """
    w = weights / weights.sum()
    xy = particles[:, :2]
    mu = w @ xy
    m_cos, m_sin = w @ np.cos(particles[:, 2]), w @ np.sin(particles[:, 2])
    cov = np.zeros((3, 3))
    cov[:2, :2] = (xy * w[:, None]).T @ xy - np.outer(mu, mu)
    r = math.hypot(m_cos, m_sin)
    cov[2, 2] = -2.0 * math.log(r) if r > 0.0 else math.inf
    return np.array([mu[0], mu[1], math.atan2(m_sin, m_cos)]), cov


@dataclass
class Hypothesis:
    """One cluster of particles: total weight [-], count, mean pose, covariance."""

    weight: float
    count: int
    mean: np.ndarray       # (x [m], y [m], yaw [rad])
    covariance: np.ndarray  # (3, 3) [m^2, rad^2]


def cluster_stats(particles, weights):
    """Per-cluster statistics, vectorized (bincount): a dict of arrays over clusters.

    weight (C,), count (C,), mean (C, 3) and cov (C, 3, 3), as weighted_pose_stats
    computes them for each cluster's own (normalised) weights.
    """
    labels = particle_clusters(particles)
    c = int(labels.max()) + 1
    w = weights if float(weights.sum()) > 0.0 else np.ones(weights.size)

    def wsum(v):
        return np.bincount(labels, weights=w * v, minlength=c)

    x, y, yaw = particles[:, 0], particles[:, 1], particles[:, 2]
    sw = np.bincount(labels, weights=w, minlength=c)
    count = np.bincount(labels, minlength=c)
    safe = np.where(sw > 0.0, sw, 1.0)
    mx, my = wsum(x) / safe, wsum(y) / safe
    mc, ms = wsum(np.cos(yaw)) / safe, wsum(np.sin(yaw)) / safe
    cov = np.zeros((c, 3, 3))
    cov[:, 0, 0] = wsum(x * x) / safe - mx * mx
    cov[:, 0, 1] = cov[:, 1, 0] = wsum(x * y) / safe - mx * my
    cov[:, 1, 1] = wsum(y * y) / safe - my * my
    r = np.hypot(mc, ms)
    with np.errstate(divide="ignore"):
        cov[:, 2, 2] = np.where(r > 0.0, -2.0 * np.log(np.where(r > 0.0, r, 1.0)), np.inf)
    mean = np.column_stack([mx, my, np.arctan2(ms, mc)])
    return {"weight": sw, "count": count, "mean": mean, "cov": cov}


def cluster_hypotheses(particles, weights, max_count=None):
    """Clusters of the set, heaviest first, as Hypothesis objects (at most max_count)."""
    st = cluster_stats(particles, weights)
    order = np.argsort(-st["weight"], kind="stable")
    if max_count is not None:
        order = order[:max_count]
    return [Hypothesis(float(st["weight"][i]), int(st["count"][i]), st["mean"][i].copy(),
                       st["cov"][i].copy()) for i in order]


# -- free space -----------------------------------------------------------------------
def free_cell_centres(grid):
    """World (x, y) [m] (M, 2) of the centres of the map's free cells (value 0)."""
    rows, cols = np.nonzero(np.asarray(grid.data) == FREE)
    ox, oy, oyaw = (float(v) for v in grid.origin)
    mx, my = (cols + 0.5) * grid.resolution, (rows + 0.5) * grid.resolution
    c, s = math.cos(oyaw), math.sin(oyaw)
    return np.column_stack([ox + c * mx - s * my, oy + s * mx + c * my])


def sample_free_poses(free_xy, resolution, origin_yaw, n, rng, out=None):
    """n poses (n, 3) uniform over free space: a free cell, a uniform point inside it,
    a uniform yaw in [-pi, pi) (amcl's uniformPoseGenerator, plus the in-cell spread)."""
    if out is None:
        out = np.empty((n, 3))
    pick = rng.integers(0, free_xy.shape[0], n)
    jitter = rng.uniform(-0.5 * resolution, 0.5 * resolution, (n, 2))
    c, s = math.cos(origin_yaw), math.sin(origin_yaw)
    out[:, 0] = free_xy[pick, 0] + c * jitter[:, 0] - s * jitter[:, 1]
    out[:, 1] = free_xy[pick, 1] + s * jitter[:, 0] + c * jitter[:, 1]
    out[:, 2] = rng.uniform(-math.pi, math.pi, n)
    return out


# -- the filter -----------------------------------------------------------------------
class ParticleFilter:
    """amcl's particle filter on one map.

    config: amcl_config.AmclConfig; grid: summit_nav_common.map_io.GridMap (the map);
    rng: numpy Generator (all randomness); laser_model: optional model with
    ``weights(particles, ranges, bearings, laser_xy, range_max, out)`` (default: the one
    named by laser_model_type). Starts from initial_pose_* / initial_cov_*.
    reset_recovery_on_injection: reset w_slow and w_fast after random particles were
    injected, as amcl does (True), or keep them, as Probabilistic Robotics' augmented
    MCL does (False, default: injection continues while the robot is lost, which is
    what recovers a kidnapped robot).
    """

    def __init__(self, config, grid, rng, laser_model=None, reset_recovery_on_injection=False):
        config.validate()
        self.reset_recovery_on_injection = reset_recovery_on_injection
        self.cfg = config
        self.grid = grid
        self.rng = rng
        self.laser = laser_model if laser_model is not None else make_laser_model(grid, config)
        self._free_xy = free_cell_centres(grid)
        if self._free_xy.shape[0] == 0:
            raise ValueError("the map has no free cell (value 0): nothing to localize in")
        cap = config.max_particles
        self._sets = [np.zeros((cap, 3)), np.zeros((cap, 3))]
        self._current = 0
        self._weights = np.full(cap, 1.0 / cap)
        self._likelihood = np.empty(cap)
        self._noise = np.empty((cap, 3))
        self.n = 0
        self.w_slow = 0.0
        self.w_fast = 0.0
        self._odom_at_update = None   # amcl's pf_odom_pose_
        self._initialized = False     # amcl's pf_init_: False -> next scan is always used
        self._force_update = False    # amcl's m_force_update (request_nomotion_update)
        self._resample_count = 0
        self._map_to_odom = None      # cached map->odom of the last update
        self._have_update = False     # has any update happened (map->odom defined)
        self._hyps = None             # cluster cache, cleared when the set changes
        self._global_init = False     # spread by global_localization since the last set_pose
        self.resampled = False        # did the last update() resample
        self.last_scan_likelihood = 0.0  # per-beam likelihood of the last scan (w_avg)
        self.set_pose(config.initial_pose(), config.initial_cov())

    # -- the particle set ------------------------------------------------------------
    @property
    def particles(self):
        """(N, 3) view of the current particles (x [m], y [m], yaw [rad]); the particlecloud."""
        return self._sets[self._current][:self.n]

    @property
    def weights(self):
        """(N,) view of the normalised weights."""
        return self._weights[:self.n]

    def _reset_set(self, n):
        self.n = n
        self._weights[:n] = 1.0 / n
        self.w_slow = self.w_fast = 0.0
        self._initialized = False
        self._hyps = None

    def set_pose(self, mean, cov):
        """(Re)initialise max_particles from a Gaussian (amcl's pf_init; the initialpose).

        mean: (x [m], y [m], yaw [rad]); cov: (3, 3) [m^2, rad^2] symmetric positive
        semi-definite (or a length-3 diagonal). ValueError on non-finite or bad input.
        """
        mean = np.asarray(mean, dtype=np.float64).reshape(-1)
        cov = np.asarray(cov, dtype=np.float64)
        if cov.ndim == 1:
            cov = np.diag(cov)
        if mean.shape != (3,) or cov.shape != (3, 3):
            raise ValueError(f"set_pose needs a (3,) mean and (3, 3) covariance, got "
                             f"{mean.shape} and {cov.shape}")
        if not (np.all(np.isfinite(mean)) and np.all(np.isfinite(cov))):
            raise ValueError("set_pose: mean and covariance must be finite")
        if not np.allclose(cov, cov.T, atol=1e-9):
            raise ValueError("set_pose: covariance must be symmetric")
        evals, evecs = np.linalg.eigh(cov)
        if evals.min() < -1e-9 * max(1.0, evals.max()):
            raise ValueError(f"set_pose: covariance is not positive semi-definite (eigenvalues {evals})")
        n = self.cfg.max_particles
        z = self.rng.standard_normal((n, 3))
        p = self._sets[self._current]
        p[:n] = mean + (z * np.sqrt(np.maximum(evals, 0.0))) @ evecs.T
        p[:n, 2] = motion_model.wrap_angle(p[:n, 2])
        self._reset_set(n)
        self._global_init = False

    def global_localization(self):
        """Spread max_particles uniformly over the free cells (amcl's global_localization)."""
        n = self.cfg.max_particles
        sample_free_poses(self._free_xy, self.grid.resolution, float(self.grid.origin[2]), n,
                          self.rng, out=self._sets[self._current][:n])
        self._reset_set(n)
        self._global_init = True

    def request_nomotion_update(self):
        """Use the next scan even if the robot has not moved (amcl's service)."""
        self._force_update = True

    # -- the update ------------------------------------------------------------------
    def update(self, odom_pose, ranges, angles, laser_pose_in_base, range_min=0.0, range_max=None):
        """Feed one scan with the odometry pose at its time; returns True if the filter updated.

        odom_pose: (x [m], y [m], yaw [rad]) of the base in the odom frame;
        ranges: (B,) [m] (inf / NaN for no return); angles: (B,) beam angles [rad] in
        the laser frame; laser_pose_in_base: (x [m], y [m], yaw [rad]) of the laser in
        the base frame; range_min, range_max: the scan's limits [m] (laser_min_range /
        laser_max_range narrow them as in amcl; range_max None -> laser_max_range).
        """
        odom = np.asarray(odom_pose, dtype=np.float64).reshape(3)
        if not np.all(np.isfinite(odom)):
            raise ValueError(f"update: odometry pose must be finite, got {odom}")
        ranges = np.asarray(ranges, dtype=np.float64)
        angles = np.asarray(angles, dtype=np.float64)
        if ranges.shape != angles.shape or ranges.ndim != 1:
            raise ValueError(f"update: ranges {ranges.shape} and angles {angles.shape} must "
                             "be equal-length 1-D arrays")
        if range_max is None:
            if self.cfg.laser_max_range <= 0:
                raise ValueError("update: give the scan's range_max (laser_max_range is not set)")
            range_max = self.cfg.laser_max_range
        self.resampled = False
        if not self.update_due(odom):
            return False
        if not self._initialized:
            self._initialized = True
            self._resample_count = 0
            self._force_update = False
        else:
            self._force_update = False
            self.apply_motion(motion_model.odom_delta(odom, self._odom_at_update), self._odom_at_update[2])
        self.apply_scan(ranges, angles, laser_pose_in_base, range_min, range_max)
        self._odom_at_update = odom
        self._resample_count += 1
        if self._resample_count % self.cfg.resample_interval == 0:
            self.resampled = self.resample()
        if self._global_init and self.cfg.recovery_global_only and self.resampled and \
                self.w_fast >= self.cfg.recovery_likelihood_threshold and self.converged:
            self._global_init = False   # localized: tracking from here, no more random particles
        self._map_to_odom = None      # computed from this update's set when first asked
        self._have_update = True
        return True

    def update_due(self, odom_pose):
        """Would update() use a scan taken at odom_pose (x [m], y [m], yaw [rad])?

        amcl's gating: the first scan after (re)initialisation, a requested no-motion
        update, or odometry moved more than update_min_d along x or y or more than
        update_min_a in yaw since the last update. Cheap (no arrays): the node asks before
        it converts a scan, so the scans the filter would skip cost next to nothing.
        """
        if not self._initialized or self._force_update:
            return True
        last = self._odom_at_update
        return (abs(odom_pose[0] - last[0]) > self.cfg.update_min_d
                or abs(odom_pose[1] - last[1]) > self.cfg.update_min_d
                or abs(float(motion_model.angle_diff(odom_pose[2], last[2]))) > self.cfg.update_min_a)

    def apply_motion(self, delta, old_yaw):
        """Move every particle by the odometry increment delta (odom frame) [m, m, rad]."""
        p = self.particles
        motion_model.sample_motion(self.cfg.odom_model_type, p, delta, old_yaw,
                                   self.cfg.odom_alphas(), self.rng,
                                   noise=self._noise[:self.n], out=p)
        self._hyps = None

    def apply_scan(self, ranges, angles, laser_pose_in_base, range_min, range_max):
        """Weight the particles by one scan and update w_slow / w_fast (amcl's
        pf_update_sensor). Returns the expected scan likelihood w_avg."""
        range_min, range_max = scan_limits(range_min, range_max, self.cfg.laser_min_range,
                                           self.cfg.laser_max_range)
        use = select_beams(ranges.shape[0], self.cfg.laser_max_beams)
        r = prepare_ranges(ranges[use], range_min, range_max)
        bearings = angles[use] + float(laser_pose_in_base[2])
        laser_xy = (float(laser_pose_in_base[0]), float(laser_pose_in_base[1]))
        p = self.laser.weights(self.particles, r, bearings, laser_xy, range_max,
                               out=self._likelihood[:self.n])
        w = self.weights
        w *= p
        total = float(w.sum())
        self._hyps = None
        if not (total > 0.0 and math.isfinite(total)):
            w[:] = 1.0 / self.n
            return 0.0
        w /= total
        # sum(w_prev * p) is the expected likelihood of this scan; augmented MCL averages
        # it per beam so that scans with different beam counts compare fairly.
        w_avg = total
        if hasattr(self.laser, "per_beam_likelihood"):
            w_avg = self.laser.per_beam_likelihood(total, self.laser.last_beams)
        self.last_scan_likelihood = w_avg
        if w_avg <= 0.0:
            return w_avg
        self.w_slow = w_avg if self.w_slow == 0.0 else self.w_slow + self.cfg.recovery_alpha_slow * (w_avg - self.w_slow)
        self.w_fast = w_avg if self.w_fast == 0.0 else self.w_fast + self.cfg.recovery_alpha_fast * (w_avg - self.w_fast)
        return w_avg

    def injection_probability(self):
        """Augmented MCL: probability max(0, 1 - w_fast / w_ref) of a random particle,
        w_ref = max(w_slow, recovery_likelihood_threshold) while recovery is on
        (recovery_alpha_fast > 0) after global_localization(), else w_slow; 0 before the
        first scan."""
        if self.w_slow <= 0.0 or (self.cfg.recovery_global_only and not self._global_init):
            return 0.0
        w_ref = self.w_slow
        if self.cfg.recovery_alpha_fast > 0.0 and self._global_init:
            w_ref = max(w_ref, self.cfg.recovery_likelihood_threshold)
        return max(0.0, 1.0 - self.w_fast / w_ref)

    def resample(self):
        """KLD-sampling low-variance resampling with random injection; returns True if done.

        With selective_resampling, skipped while N_eff = 1 / sum(w^2) > N / 2.
        """
        w = self.weights
        if self.cfg.selective_resampling and 1.0 / float(w @ w) > 0.5 * self.n:
            return False
        c = self.cfg
        m = c.max_particles
        w_diff = self.injection_probability()
        src = self.particles
        dst = self._sets[1 - self._current]
        idx = low_variance_indices(w, m, self.rng)
        self.rng.shuffle(idx)  # random order, so every prefix is a fair sample
        np.take(src, idx, axis=0, out=dst[:m])
        if w_diff > 0.0:
            rand = self.rng.random(m) < w_diff
            k = int(rand.sum())
            if k:
                dst[:m][rand] = sample_free_poses(self._free_xy, self.grid.resolution,
                                                  float(self.grid.origin[2]), k, self.rng)
        # KLD: number of distinct bins among the first j candidates, for every j.
        keys = histogram_keys(dst[:m])
        _, first = np.unique(keys, return_index=True)
        new_bin = np.zeros(m, np.int64)
        new_bin[first] = 1
        bins_so_far = np.cumsum(new_bin)
        limit = kld_limit(bins_so_far, c.kld_err, c.kld_z, c.min_particles, m)
        done = np.flatnonzero(np.arange(1, m + 1) > limit)
        n_new = int(done[0]) + 1 if done.size else m
        self._current = 1 - self._current
        self.n = n_new
        self._weights[:n_new] = 1.0 / n_new
        self._hyps = None
        if w_diff > 0.0 and self.reset_recovery_on_injection:
            self.w_slow = self.w_fast = 0.0
        return True

    # -- outputs ---------------------------------------------------------------------
    def hypotheses(self, max_count=10):
        """Clusters of the current set, heaviest first (list of at most max_count Hypothesis)."""
        if self._hyps is None:
            self._hyps = cluster_stats(self.particles, self.weights)
        st = self._hyps
        order = np.argsort(-st["weight"], kind="stable")[:max_count]
        return [Hypothesis(float(st["weight"][i]), int(st["count"][i]), st["mean"][i].copy(),
                           st["cov"][i].copy()) for i in order]

    def estimate(self):
        """(pose (3,), covariance (3, 3)) as amcl publishes amcl_pose: the heaviest
        cluster's mean, the whole set's covariance [m^2, rad^2]."""
        best = self.hypotheses(max_count=1)[0]
        _, cov = weighted_pose_stats(self.particles, self.weights)
        return best.mean.copy(), cov

    @property
    def covariance(self):
        """(3, 3) covariance of the whole set (amcl_pose's covariance)."""
        return weighted_pose_stats(self.particles, self.weights)[1]

    @property
    def converged(self):
        """amcl's pf convergence: every particle within 0.5 m of the mean along x and y."""
        return converged(self.particles, CONVERGED_DIST)

    def map_to_odom(self):
        """Transform (x [m], y [m], yaw [rad]) map -> odom, or None before the first update.

        estimate() (+) inverse(odometry pose of the last update), computed (clustering)
        when first asked after an update and kept until the next update, so the tf
        amcl broadcasts between updates stays put even if the particles are re-seeded.
        """
        if not self._have_update:
            return None
        if self._map_to_odom is None:
            est, _ = self.estimate()
            self._map_to_odom = compose(est, inverse(self._odom_at_update))
        return self._map_to_odom.copy()

    def pose_at(self, odom_pose):
        """Map pose of the base at odometry pose odom_pose (map->odom (+) odom), or None."""
        m2o = self.map_to_odom()
        return None if m2o is None else compose(m2o, odom_pose)

    @property
    def odom_at_update(self):
        """Odometry pose (3,) of the last filter update (amcl's pf_odom_pose_), or None."""
        return None if self._odom_at_update is None else self._odom_at_update.copy()
