"""Range models of the simulated laser: what the scanner reports, given the exact ranges.

The simulator casts every beam exactly (summit_nav_common.raycast); a model here turns
those exact ranges, and the incidence angle of each beam on the surface it hit, into the
ranges a scanner would publish. Two models, chosen by the simulator's ``laser_model``
parameter (one small interface: ``measure``):

``ideal``    the exact range plus Gaussian noise of ``noise_sigma`` (1 cm by default).
``utm30lx``  the Hokuyo UTM-30LX as its datasheet states it, with the two failure modes
             every pulsed 2D scanner shows on real data:
  1. Range noise by band: the datasheet's accuracy is +-30 mm from 0.1 to 10 m and
     +-50 mm from 10 to 30 m. Hokuyo writes a dispersion as a sigma where it means one
     (the UTM-30LX-EW sheet gives "repeated accuracy" as sigma < 10 mm within 10 m,
     beside the same +-30 mm accuracy), so a bare +- is a bound on the error: we take
     it as 3 sigma, i.e. sigma = 10 mm within 10 m and 16.7 mm beyond.
  2. Mixed pixels at depth edges (Hebert & Krotkov 1992, "3D measurements from imaging
     laser radars: how good are they?"; Ye & Borenstein 2002, "Characterization of a 2-D
     laser scanner for mobile robot obstacle negotiation"): a beam's footprint that
     straddles a depth discontinuity returns light from both surfaces, and the range
     reported lies between them: a point floating in free space. Neighbouring beams
     whose exact ranges jump by more than one plane could produce (seen at up to
     EDGE_MAX_INCIDENCE) bracket an edge; the edge lies at a uniform position between
     the two beam centres; each footprint is FOOTPRINT_STEPS angular steps wide (the
     datasheet gives no divergence: we take the footprints of neighbouring beams to
     touch); a beam whose footprint the edge crosses sees a fraction f of the other
     surface, and with probability MIXED_PIXEL_PROB reports its own range moved by f
     towards the other one.
  3. No return at grazing incidence (Kneip et al. 2009, "Characterization of the
     compact Hokuyo URG-04LX 2D laser range scanner", measured the loss with the
     incidence angle): the light scattered back falls with cos(incidence), and beyond
     GRAZING_START the return is lost with a probability rising linearly to 1 at 90 deg;
     a lost return is +inf (REP 117). The incidence is taken on the surface hit: the
     cell edge the beam stopped at (walls) or the box / robot face.
Mixed pixels are computed from the exact ranges, then the noise is added, then the
dropouts remove returns. Everything is vectorized over the beams with a fixed number of
draws per scan (so a seed gives the same scans whatever the scene); ``measure_reference``
is the per-beam loop kept as the test oracle, drawing the same numbers.
"""
import math
from dataclasses import dataclass

import numpy as np

LASER_MODELS = ("utm30lx", "ideal")
DEFAULT_LASER_MODEL = "utm30lx"


def report(ranges, range_min, range_max, no_return):
    """Ranges as published: clipped to [range_min, range_max], +inf where no return."""
    out = np.minimum(np.maximum(ranges, range_min), range_max)  # np.clip, without its overhead
    out[no_return] = np.inf
    return out.astype(np.float32)


@dataclass(frozen=True)
class IdealLaser:
    """Exact range plus Gaussian noise of ``sigma`` [m]."""

    sigma: float = 0.01  # [m]
    name = "ideal"
    needs_incidence = False  # measure ignores cos_incidence (the caller may pass None)

    def measure(self, ranges, cos_incidence, angle_increment, range_min, range_max, rng):
        """Reported ranges (float32) from exact ``ranges`` [m]; cos_incidence unused.

        Beams at range_max or beyond (nothing hit) report +inf.
        """
        no_return = ranges >= range_max
        if self.sigma > 0:
            ranges = ranges + rng.normal(0.0, self.sigma, ranges.shape)
        return report(ranges, range_min, range_max, no_return)


@dataclass(frozen=True)
class Utm30lxLaser:
    """Hokuyo UTM-30LX: banded noise, mixed pixels at depth edges, grazing dropouts."""

    band_edge: float = 10.0                  # [m] where the datasheet's accuracy changes
    sigma_near: float = 0.030 / 3.0          # [m] +-30 mm (0.1-10 m) read as 3 sigma
    sigma_far: float = 0.050 / 3.0           # [m] +-50 mm (10-30 m) read as 3 sigma
    footprint_steps: float = 1.0             # beam footprint width [angular steps]
    mixed_pixel_prob: float = 0.5            # a straddling footprint reports a mixed range
    edge_min_jump: float = 0.10              # [m] smallest depth jump counted as an edge
    edge_max_incidence: float = math.radians(85.0)  # planes up to this incidence are no edge
    grazing_start: float = math.radians(80.0)      # [rad] incidence where returns start to drop
    name = "utm30lx"
    needs_incidence = True

    def sigma(self, ranges):
        """Range noise sigma [m] for exact ``ranges`` [m] (datasheet band)."""
        return np.where(ranges <= self.band_edge, self.sigma_near, self.sigma_far)

    def dropout_prob(self, cos_incidence):
        """Probability of no return at incidence acos(cos_incidence): 0 below
        grazing_start, rising linearly to 1 at 90 deg."""
        incidence = np.arccos(np.minimum(np.maximum(cos_incidence, 0.0), 1.0))
        return np.minimum(np.maximum((incidence - self.grazing_start) / (math.pi / 2 - self.grazing_start), 0.0), 1.0)

    def _draws(self, n, rng):
        # Fixed count and order per scan: noise (n normals), then one block of uniforms:
        # edge positions (n - 1), mixed-or-not (n - 1), dropouts (n).
        gauss = rng.standard_normal(n)
        m = max(n - 1, 0)
        u = rng.random(2 * m + n)
        return gauss, u[:m], u[m:2 * m], u[2 * m:]

    def _edge_jump(self, near, angle_increment):
        """Smallest depth jump [m] between neighbouring beams counted as an edge: more
        than a plane seen at edge_max_incidence gives (near * step * tan(incidence))."""
        return np.maximum(self.edge_min_jump, near * angle_increment * math.tan(self.edge_max_incidence))

    def measure(self, ranges, cos_incidence, angle_increment, range_min, range_max, rng):
        """Reported ranges (float32) from exact ``ranges`` [m] and the |cos| of each beam's
        incidence; angle_increment [rad] between beams; rng: numpy Generator."""
        ranges = np.asarray(ranges, dtype=np.float64)
        n = ranges.shape[0]
        gauss, u_edge, u_mixed, u_drop = self._draws(n, rng)
        hit = ranges < range_max
        out = ranges.copy()
        if n > 1:
            left, right = ranges[:-1], ranges[1:]
            edge = hit[:-1] & hit[1:] & (np.abs(right - left) > self._edge_jump(np.minimum(left, right), angle_increment))
            half = self.footprint_steps / 2.0
            # Fraction of each footprint beyond the edge at u (0 = left beam's centre, 1 = right's).
            f_left = np.minimum(np.maximum((half - u_edge) / self.footprint_steps, 0.0), 1.0)
            f_right = np.minimum(np.maximum((u_edge - (1.0 - half)) / self.footprint_steps, 0.0), 1.0)
            mixed = edge & (u_mixed < self.mixed_pixel_prob)
            # The left update of a beam (its own edge to the right) wins over the right
            # update (the edge to its left), as in the reference loop's order.
            k = np.flatnonzero(mixed & (f_right > 0.0))
            out[k + 1] = right[k] + f_right[k] * (left[k] - right[k])
            k = np.flatnonzero(mixed & (f_left > 0.0))
            out[k] = left[k] + f_left[k] * (right[k] - left[k])
        out += gauss * self.sigma(out)
        no_return = ~hit
        grazing = np.flatnonzero(hit & (cos_incidence < math.cos(self.grazing_start)))
        no_return[grazing] = u_drop[grazing] < self.dropout_prob(cos_incidence[grazing])
        return report(out, range_min, range_max, no_return)

    def measure_reference(self, ranges, cos_incidence, angle_increment, range_min, range_max, rng):
        """Slow per-beam version of measure (the test oracle): same draws, same result.

        A beam between two edges takes the mixed range of the edge on its right.
        """
        ranges = [float(r) for r in ranges]
        n = len(ranges)
        gauss, u_edge, u_mixed, u_drop = self._draws(n, rng)
        half = self.footprint_steps / 2.0

        def mixed_range(k, edge, own_side_u):
            # Beam k's range when the edge between beams edge and edge+1 mixes it, else None.
            if edge < 0 or edge >= n - 1:
                return None
            a, b = ranges[edge], ranges[edge + 1]
            if a >= range_max or b >= range_max or u_mixed[edge] >= self.mixed_pixel_prob:
                return None
            if abs(b - a) <= max(self.edge_min_jump, min(a, b) * angle_increment * math.tan(self.edge_max_incidence)):
                return None
            f = min(max((half - own_side_u) / self.footprint_steps, 0.0), 1.0)
            if f <= 0.0:
                return None
            own, other = (a, b) if k == edge else (b, a)
            return own + f * (other - own)

        result = np.empty(n)
        lost = np.zeros(n, bool)
        for k in range(n):
            r = mixed_range(k, k, u_edge[k] if k < n - 1 else 1.0)
            if r is None:
                r = mixed_range(k, k - 1, 1.0 - u_edge[k - 1] if k > 0 else 1.0)
            if r is None:
                r = ranges[k]
            sigma = self.sigma_near if r <= self.band_edge else self.sigma_far
            result[k] = r + gauss[k] * sigma
            incidence = math.acos(min(max(float(cos_incidence[k]), 0.0), 1.0))
            p = min(max((incidence - self.grazing_start) / (math.pi / 2 - self.grazing_start), 0.0), 1.0)
            lost[k] = ranges[k] >= range_max or u_drop[k] < p
        return report(result, range_min, range_max, lost)


def make_laser_model(name, noise_sigma=0.01):
    """The range model called ``name`` (LASER_MODELS); noise_sigma [m] is the ideal model's.

    ValueError naming the parameter when the name is unknown.
    """
    if name == "ideal":
        if not (math.isfinite(noise_sigma) and noise_sigma >= 0):
            raise ValueError(f"laser_noise must be a finite sigma >= 0 [m], got {noise_sigma!r}")
        return IdealLaser(sigma=float(noise_sigma))
    if name == "utm30lx":
        return Utm30lxLaser()
    raise ValueError(f"laser_model must be one of {', '.join(LASER_MODELS)}, got {name!r}")
