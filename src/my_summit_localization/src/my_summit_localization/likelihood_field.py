"""amcl's laser models: likelihood field (default), likelihood_field_prob, and beam.

Algorithms (Thrun, Burgard, Fox, Probabilistic Robotics, ch. 6.4 and 6.3), as ROS amcl
implements them in ``AMCLLaser::LikelihoodFieldModel``, ``LikelihoodFieldModelProb``
and ``BeamModel`` (amcl/src/amcl/sensors/amcl_laser.cpp):

likelihood_field_range_finder_model: the end point of every used beam is looked up in a
precomputed field of the distance ``d`` to the nearest occupied cell (capped at
laser_likelihood_max_dist; off the map counts as the cap); each beam gives
``pz = z_hit * exp(-d^2 / (2 sigma_hit^2)) + z_rand / range_max`` and amcl combines the
beams as ``p = 1 + sum(pz^3)`` (an ad-hoc combination that keeps one bad beam from
killing a particle). Beams at or beyond range_max are skipped (no return).

Here the per-cell value ``pz^3`` is precomputed into a lookup table (one per range_max),
padded by one cell of the off-map value, so the update of the whole particle set is
array arithmetic for the (N, B) end points, one gather and one row sum. The table is
rebuilt only if the scan's range_max changes. ``likelihood_field_reference`` is the
slow, obvious per-particle per-beam version kept as the test oracle.

likelihood_field_prob: the same pz, combined as ``p = exp(sum(log pz))`` (a true
product), with amcl's optional beam skipping (do_beamskip: beams whose end point agrees
with the map, d < beam_skip_distance, for fewer than beam_skip_threshold of the
particles are left out, unless more than beam_skip_error_threshold of the beams would
be; ours: with beam_skip_converged_only, only while the particle set is converged, so a
spread cloud during global localization weighs every beam).

beam_range_finder_model: each beam's expected range is ray cast from every particle
(``summit_nav_common.raycast.cast_rays``, exact to the grid; Walsh & Karaman 2017 with
Amanatides & Woo 1987), and ``pz = z_hit N(z - z*) + z_short (z < z*) lambda e^{-lambda
z} + z_max [z = range_max] + z_rand [z < range_max] / range_max``, combined as amcl does
(``1 + sum(pz^3)``). Rays are cast one particle at a time (N calls into the compiled
caster), which is far slower than the likelihood field; amcl's default is the latter.

Beams used: amcl's subsampling, every ``step = (n - 1) // (laser_max_beams - 1)``-th
beam from the first (integer division as in C, at least 1).

Frames and units: particles (N, 3) (x [m], y [m], yaw [rad]) of base_footprint in the
map frame; ranges [m]; bearings [rad] of the beams in the *base* frame (laser angle +
laser mount yaw); laser_xy (x, y) [m] of the laser in the base frame. The map may have
an origin yaw (map_server's origin); poses are taken into the grid frame first.
"""
import math

import numpy as np

from summit_nav_common.distance import bounded_distance_field, distance_field

OCCUPIED = 100   # OccupancyGrid value amcl treats as an obstacle (occ_state +1)
FREE = 0         # value amcl counts as free space (occ_state -1)
PAD = 1          # cells of padding around the lookup table (off-map end points land there)
MODELS = ("likelihood_field", "likelihood_field_prob", "beam")


# -- scan preparation (amcl_node.cpp laserReceived) ------------------------------------
def select_beams(n_ranges, max_beams):
    """Indices of the beams amcl uses: every step-th from 0, step = (n-1)//(max_beams-1)."""
    if n_ranges <= 0:
        return np.zeros(0, np.int64)
    step = max(1, (n_ranges - 1) // (max_beams - 1)) if max_beams > 1 else 1
    return np.arange(0, n_ranges, step, dtype=np.int64)


def scan_limits(scan_range_min, scan_range_max, laser_min_range=-1.0, laser_max_range=-1.0):
    """(range_min, range_max) [m] amcl uses: the scan's, narrowed by laser_min/max_range > 0."""
    range_min = max(scan_range_min, laser_min_range) if laser_min_range > 0 else scan_range_min
    range_max = min(scan_range_max, laser_max_range) if laser_max_range > 0 else scan_range_max
    return float(range_min), float(range_max)


def prepare_ranges(ranges, range_min, range_max):
    """Ranges [m] as amcl's models see them: <= range_min becomes range_max (amcl_node),
    and beyond range_max (e.g. +inf no-returns) becomes range_max too. NaN stays NaN."""
    r = np.asarray(ranges, dtype=np.float64).copy()
    with np.errstate(invalid="ignore"):
        r[r <= range_min] = range_max
        r[r > range_max] = range_max
    return r


# -- the map side ---------------------------------------------------------------------
def obstacle_distance_field(data, resolution, max_dist):
    """Distance [m] from each cell centre to the nearest occupied cell centre, capped.

    data: (H, W) OccupancyGrid values (100 = occupied); max_dist: cap [m]
    (laser_likelihood_max_dist), amcl's map_update_cspace. Returns (H, W) float64.
    """
    occupied = np.asarray(data) == OCCUPIED
    if not occupied.any():
        return np.full(occupied.shape, float(max_dist))
    # exact up to one cell beyond the cap; anything farther is capped anyway
    cells = bounded_distance_field(occupied, max_dist / resolution + 1.0)
    return np.minimum(cells.astype(np.float64) * resolution, max_dist)


def hit_likelihood(dist, z_hit, z_rand, sigma_hit, range_max):
    """Per-beam pz [-] for an end point at obstacle distance ``dist`` [m]."""
    return z_hit * np.exp(-(np.asarray(dist) ** 2) / (2.0 * sigma_hit ** 2)) + z_rand / range_max


class _GridFrame:
    """Map geometry: world poses -> grid-frame poses in cells (origin yaw honoured)."""

    def __init__(self, grid):
        self.resolution = float(grid.resolution)
        self.ox, self.oy, self.oyaw = (float(v) for v in grid.origin)
        self.c0, self.s0 = math.cos(self.oyaw), math.sin(self.oyaw)
        self.height, self.width = grid.data.shape

    def poses_to_cells(self, particles):
        """(gx [cells], gy [cells], yaw [rad]) of (N, 3) world poses in the grid frame."""
        dx = particles[:, 0] - self.ox
        dy = particles[:, 1] - self.oy
        inv = 1.0 / self.resolution
        gx = (self.c0 * dx + self.s0 * dy) * inv
        gy = (-self.s0 * dx + self.c0 * dy) * inv
        return gx, gy, particles[:, 2] - self.oyaw


class LikelihoodFieldModel:
    """amcl's likelihood_field (and likelihood_field_prob) laser model, vectorized.

    grid: summit_nav_common.map_io.GridMap; config: AmclConfig (laser_* parameters).
    dtype: float type of the (N, B) end-point arithmetic (float32: fast, a few 1e-5
    cells of rounding; float64: the reference's cells except at exact cell borders).
    The lookup table itself is float32 (relative error ~1e-7).
    """

    def __init__(self, grid, config, dtype=np.float32):
        self.cfg = config
        self.frame = _GridFrame(grid)
        self.dtype = np.dtype(dtype)
        self.max_dist = float(config.laser_likelihood_max_dist)
        dist = obstacle_distance_field(grid.data, grid.resolution, self.max_dist)
        h, w = dist.shape
        padded = np.full((h + 2 * PAD, w + 2 * PAD), self.max_dist)
        padded[PAD:PAD + h, PAD:PAD + w] = dist
        self.dist = padded[PAD:PAD + h, PAD:PAD + w]   # a view: the field is not kept twice
        self._dist_padded = padded
        self._row_stride = w + 2 * PAD
        self._table = None          # flattened per-cell value (pz^3 or log pz)
        self._table_range_max = None
        self._dist_flat = padded.ravel().astype(np.float32)
        self._buf = {}
        self.last_beams = 0         # beams used by the last weights() call
        self.last_log_offset = 0.0  # prob model: weights() returned p * exp(-offset)

    # -- tables --------------------------------------------------------------------
    def table(self, range_max):
        """Flattened padded lookup table of the per-cell beam value for this range_max."""
        if self._table is None or self._table_range_max != range_max:
            c = self.cfg
            pz = hit_likelihood(self._dist_padded, c.laser_z_hit, c.laser_z_rand,
                                c.laser_sigma_hit, range_max)
            value = np.log(pz) if c.laser_model_type == "likelihood_field_prob" else pz ** 3
            self._table = value.ravel().astype(np.float32)
            self._table_range_max = range_max
        return self._table

    def _buffers(self, n, b):
        """Preallocated (n, b) work arrays, grown when a bigger set arrives.

        With a 4-byte dtype (the default float32) the six arrays share three blocks:
        each is written only after the one it shares with is read for the last time
        (ix over tmp, iy over ex, val over ey; see cell_indices and weights), which
        halves the model's memory (7.2 -> 3.6 MB at 5000 particles x 60 beams) with
        the same operations, so the same results.
        """
        have = self._buf.get("shape", (0, 0))
        if have[0] < n or have[1] < b:
            shape = (max(n, have[0]), max(b, have[1]))
            ex, ey, tmp = (np.empty(shape, self.dtype) for _ in range(3))
            if self.dtype.itemsize == 4:
                ix, iy, val = tmp.view(np.int32), ex.view(np.int32), ey.view(np.float32)
            else:
                ix, iy = np.empty(shape, np.int32), np.empty(shape, np.int32)
                val = np.empty(shape, np.float32)
            self._buf = {"shape": shape, "ex": ex, "ey": ey, "tmp": tmp, "ix": ix, "iy": iy, "val": val}
        return {k: (v[:n, :b] if k != "shape" else v) for k, v in self._buf.items()}

    # -- the model -----------------------------------------------------------------
    def cell_indices(self, particles, ranges, bearings, laser_xy):
        """Flat indices (N, B) int32 into the padded table of every beam's end point."""
        f = self.frame
        n, b = particles.shape[0], ranges.shape[0]
        buf = self._buffers(n, b)
        gx, gy, yaw = f.poses_to_cells(particles)
        c, s = np.cos(yaw), np.sin(yaw)
        lx, ly = laser_xy[0] / f.resolution, laser_xy[1] / f.resolution
        dt = self.dtype
        # Laser origin of each particle [cells], shifted by the padding.
        sx = (gx + lx * c - ly * s + PAD).astype(dt)[:, None]
        sy = (gy + lx * s + ly * c + PAD).astype(dt)[:, None]
        c, s = c.astype(dt)[:, None], s.astype(dt)[:, None]
        rc = (ranges * np.cos(bearings) / f.resolution).astype(dt)[None, :]
        rs = (ranges * np.sin(bearings) / f.resolution).astype(dt)[None, :]
        ex, ey, tmp = buf["ex"], buf["ey"], buf["tmp"]
        # End point = origin + R(yaw) (r cos b, r sin b), for all particles x beams.
        np.multiply(c, rc, out=ex)
        np.multiply(s, rs, out=tmp)
        np.subtract(ex, tmp, out=ex)
        np.add(ex, sx, out=ex)
        np.multiply(s, rc, out=ey)
        np.multiply(c, rs, out=tmp)
        np.add(ey, tmp, out=ey)
        np.add(ey, sy, out=ey)
        # Clip into the padded grid (off-map lands on the padding, which holds the
        # off-map value) and truncate (= floor, all values are >= 0 now).
        np.clip(ex, 0, f.width + 2 * PAD - 1, out=ex)
        np.clip(ey, 0, f.height + 2 * PAD - 1, out=ey)
        ix, iy = buf["ix"], buf["iy"]
        np.copyto(ix, ex, casting="unsafe")
        np.copyto(iy, ey, casting="unsafe")
        np.multiply(iy, self._row_stride, out=iy)
        np.add(ix, iy, out=ix)
        return ix

    def weights(self, particles, ranges, bearings, laser_xy, range_max, out=None):
        """Likelihood p (N,) of a scan for every particle (amcl's per-particle factor).

        particles: (N, 3) map-frame poses of the base; ranges (B,) [m] (already
        subsampled and prepared, see prepare_ranges); bearings (B,) [rad] in the base
        frame; laser_xy: laser position (x, y) [m] in the base frame; range_max [m].
        Beams at range_max or NaN are skipped, as amcl does. likelihood_field_prob
        returns the product scaled by exp(-last_log_offset) (the largest log
        likelihood), so hundreds of beams do not underflow to 0.
        """
        n = particles.shape[0]
        if out is None:
            out = np.empty(n, np.float64)
        ranges = np.asarray(ranges, np.float64)
        use = np.isfinite(ranges) & (ranges < range_max)
        r, bb = ranges[use], np.asarray(bearings, np.float64)[use]
        prob = self.cfg.laser_model_type == "likelihood_field_prob"
        self.last_beams = int(r.size)
        self.last_log_offset = 0.0
        if r.size == 0:
            out[:] = 1.0
            return out
        idx = self.cell_indices(particles, r, bb, laser_xy)
        val = self._buffers(n, r.size)["val"]
        np.take(self.table(range_max), idx, out=val)
        if not prob:
            np.sum(val, axis=1, dtype=np.float64, out=out)
            out += 1.0
            return out
        if self.cfg.do_beamskip and (not self.cfg.beam_skip_converged_only or converged(particles)):
            keep = self._beamskip_mask(idx)
            np.sum(val[:, keep], axis=1, dtype=np.float64, out=out)
            # the per-beam likelihood is a mean over the beams scored, not the skipped ones
            self.last_beams = int(keep.sum())
        else:
            np.sum(val, axis=1, dtype=np.float64, out=out)
        # exp(sum log pz) underflows for many beams: scale by exp(-max) (the filter
        # normalises the weights anyway) and keep the offset for per_beam_likelihood.
        self.last_log_offset = float(out.max())
        out -= self.last_log_offset
        np.exp(out, out=out)
        return out

    def per_beam_likelihood(self, total, n_beams):
        """The scan's average per-beam likelihood [-] from total = sum(w_prev * p).

        likelihood_field: (total - 1) / B, the mean pz^3 (amcl's p = 1 + sum pz^3);
        likelihood_field_prob: total^(1/B), the geometric mean pz (p = prod pz).
        Used by augmented MCL so scans with different beam counts compare fairly.
        """
        if n_beams <= 0:
            return 0.0
        if self.cfg.laser_model_type == "likelihood_field_prob":
            if total <= 0:
                return 0.0
            return float(np.exp((np.log(total) + self.last_log_offset) / n_beams))
        return max(0.0, (total - 1.0) / n_beams)

    def _beamskip_mask(self, idx):
        """amcl's beam skipping: beams (B,) bool to keep (likelihood_field_prob)."""
        c = self.cfg
        agree = (self._dist_flat[idx] < c.beam_skip_distance).mean(axis=0)
        keep = agree > c.beam_skip_threshold
        skipped = int((~keep).sum())
        if skipped >= keep.size * c.beam_skip_error_threshold:
            keep[:] = True  # the filter has not converged: use every beam
        return keep


def converged(particles, dist=0.5):
    """amcl's pf convergence (pf_update_converged): every particle within dist [m] of the
    mean along x and y."""
    p = np.asarray(particles)[:, :2]
    return bool(np.all(np.abs(p - p.mean(axis=0)) <= dist))


def likelihood_field_reference(grid, config, particles, ranges, bearings, laser_xy, range_max):
    """Slow oracle of amcl's likelihood_field model: plain loops, no tables, float64."""
    c = config
    dist = obstacle_distance_field(grid.data, grid.resolution, c.laser_likelihood_max_dist)
    ox, oy, oyaw = grid.origin
    h, w = dist.shape
    out = np.empty(len(particles))
    for i, (x, y, yaw) in enumerate(particles):
        # Laser pose in the map (amcl: pf_vector_coord_add(laser_pose, sample pose)).
        lx = x + laser_xy[0] * math.cos(yaw) - laser_xy[1] * math.sin(yaw)
        ly = y + laser_xy[0] * math.sin(yaw) + laser_xy[1] * math.cos(yaw)
        p = 1.0
        for r, b in zip(ranges, bearings):
            if not r < range_max:  # skips NaN and max-range readings
                continue
            hx = lx + r * math.cos(yaw + b)
            hy = ly + r * math.sin(yaw + b)
            mx = math.cos(oyaw) * (hx - ox) + math.sin(oyaw) * (hy - oy)
            my = -math.sin(oyaw) * (hx - ox) + math.cos(oyaw) * (hy - oy)
            col, row = math.floor(mx / grid.resolution), math.floor(my / grid.resolution)
            z = dist[row, col] if (0 <= col < w and 0 <= row < h) else c.laser_likelihood_max_dist
            pz = c.laser_z_hit * math.exp(-z * z / (2.0 * c.laser_sigma_hit ** 2))
            pz += c.laser_z_rand / range_max
            p += pz ** 3
        out[i] = p
    return out


# -- beam model -----------------------------------------------------------------------
def _raycast():
    """summit_nav_common.raycast, imported on first use: its compiled caster loads numba
    (~60 MB of the node's memory), which only the beam model needs."""
    from summit_nav_common import raycast
    return raycast


def beam_pz(obs, expected, config, range_max):
    """amcl's BeamModel per-beam mixture pz for observed / expected ranges [m] (arrays)."""
    c = config
    z = obs - expected
    pz = c.laser_z_hit * np.exp(-(z * z) / (2.0 * c.laser_sigma_hit ** 2))
    pz = pz + np.where(z < 0, c.laser_z_short * c.laser_lambda_short
                       * np.exp(-c.laser_lambda_short * obs), 0.0)
    pz = pz + np.where(obs == range_max, c.laser_z_max, 0.0)
    pz = pz + np.where(obs < range_max, c.laser_z_rand / range_max, 0.0)
    return pz


class BeamModel:
    """amcl's beam laser model: ray casting from every particle (see module docstring)."""

    def __init__(self, grid, config):
        self.cfg = config
        self.frame = _GridFrame(grid)
        self.occupied = np.ascontiguousarray(np.asarray(grid.data) == OCCUPIED)
        self.dist_cells = distance_field(self.occupied)
        self.last_beams = 0         # beams used by the last weights() call

    def per_beam_likelihood(self, total, n_beams):
        """Mean pz^3 of the scan, (total - 1) / B (see LikelihoodFieldModel)."""
        return max(0.0, (total - 1.0) / n_beams) if n_beams > 0 else 0.0

    def expected_ranges(self, particles, bearings, laser_xy, range_max):
        """Ray-cast ranges (N, B) [m] of every beam from every particle; range_max for
        no hit within range or leaving the map."""
        f = self.frame
        gx, gy, yaw = f.poses_to_cells(particles)
        c, s = np.cos(yaw), np.sin(yaw)
        lx, ly = laser_xy[0] / f.resolution, laser_xy[1] / f.resolution
        sx, sy = gx + lx * c - ly * s, gy + lx * s + ly * c
        out = np.empty((particles.shape[0], len(bearings)))
        tmax = range_max / f.resolution
        bearings = np.asarray(bearings, np.float64)
        raycast = _raycast()
        for i in range(particles.shape[0]):
            raycast.cast_rays(self.occupied, self.dist_cells, sx[i], sy[i], yaw[i] + bearings,
                              tmax, out=out[i])
        out *= f.resolution
        np.minimum(out, range_max, out=out)
        return out

    def weights(self, particles, ranges, bearings, laser_xy, range_max, out=None):
        """Likelihood p (N,) = 1 + sum(pz^3) of a prepared scan for every particle."""
        ranges = np.asarray(ranges, np.float64)
        use = ~np.isnan(ranges)
        r, bb = ranges[use], np.asarray(bearings, np.float64)[use]
        if out is None:
            out = np.empty(particles.shape[0])
        self.last_beams = int(r.size)
        expected = self.expected_ranges(particles, bb, laser_xy, range_max)
        pz = beam_pz(r[None, :], expected, self.cfg, range_max)
        np.sum(pz ** 3, axis=1, out=out)
        out += 1.0
        return out


def beam_model_reference(grid, config, particles, ranges, bearings, laser_xy, range_max):
    """Slow oracle of the beam model: per particle per beam, the reference ray caster."""
    c = config
    occupied = np.asarray(grid.data) == OCCUPIED
    frame = _GridFrame(grid)
    out = np.empty(len(particles))
    for i, pose in enumerate(particles):
        gx, gy, yaw = (float(v[0]) for v in frame.poses_to_cells(np.asarray([pose], float)))
        ox = gx + (laser_xy[0] * math.cos(yaw) - laser_xy[1] * math.sin(yaw)) / frame.resolution
        oy = gy + (laser_xy[0] * math.sin(yaw) + laser_xy[1] * math.cos(yaw)) / frame.resolution
        p = 1.0
        for r, b in zip(ranges, bearings):
            if math.isnan(r):
                continue
            expected = _raycast().cast_rays_reference(occupied, ox, oy, [yaw + b],
                                                   range_max / frame.resolution)[0]
            expected = min(expected * frame.resolution, range_max)
            z = r - expected
            pz = c.laser_z_hit * math.exp(-z * z / (2.0 * c.laser_sigma_hit ** 2))
            if z < 0:
                pz += c.laser_z_short * c.laser_lambda_short * math.exp(-c.laser_lambda_short * r)
            if r == range_max:
                pz += c.laser_z_max
            if r < range_max:
                pz += c.laser_z_rand / range_max
            p += pz ** 3
        out[i] = p
    return out


def make_laser_model(grid, config):
    """The laser model named by config.laser_model_type."""
    if config.laser_model_type == "beam":
        return BeamModel(grid, config)
    if config.laser_model_type in ("likelihood_field", "likelihood_field_prob"):
        return LikelihoodFieldModel(grid, config)
    raise ValueError(f"laser_model_type must be one of {', '.join(MODELS)}, "
                     f"got {config.laser_model_type!r}")
