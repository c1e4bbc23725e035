"""Mixed pixels: the points a laser reports floating between a depth edge and the
surface behind it.

Reference: Tuley, Vandapel & Hebert 2005, "Analysis and removal of artifacts in 3-D LADAR
data" (why: a beam whose footprint straddles an edge reports a range between the two
surfaces, on its line of sight); laser_filters' ScanShadowsFilter (what ROS users run
for it: an angle test that also drops the beams on each side of every real edge and
every wall seen within its min_angle of grazing). The test here keeps both:

  beam i is a mixed pixel when its range lies more than `min_offset` inside the interval
  of its two neighbours' ranges (it floats between them), and more than `min_offset` off
  both lines its surface could continue, the line through beams i-2, i-1 and the line
  through beams i+1, i+2 (a wall, even one seen at grazing, has its points on one line).

A real edge has its beams on either surface, not between; a pole one beam wide lies in
front of both neighbours; a grazing wall's middle beam is between its neighbours but on
their line. Ranges that are not finite (no return) are never flagged, and a side whose
line cannot be drawn (a missing neighbour) vouches for nothing.

Graph SLAM's map is occupied where hits / passes exceed 0.1 (open_karto's threshold): a
floating point hits a cell that few beams cross, and one is enough to mark it. On
willow-full such dots in a corridor 1.6 m wide, inflated by the robot's radius, closed it
to the planner, and exploration ended with half the building unseen.
"""
import math

import numpy as np


def _line_range(ra, aa, rb, ab, a):
    """Range along the ray at angle a [rad] to the line through the points (ra, aa) and
    (rb, ab) (polar); inf where the line does not cross the ray in front of the laser."""
    den = ra * np.sin(a - aa) + rb * np.sin(ab - a)
    num = ra * rb * np.sin(ab - aa)
    with np.errstate(divide="ignore", invalid="ignore"):
        r = num / den
    return np.where(np.isfinite(r) & (r > 0.0), r, np.inf)


def mixed_pixel_mask(ranges: np.ndarray, angles: np.ndarray, min_offset: float) -> np.ndarray:
    """bool (n,): the beams of ranges (n,) [m] at angles (n,) [rad] that are mixed pixels
    (module docstring) at a margin of min_offset [m]; all False when min_offset <= 0."""
    r = np.asarray(ranges, float)
    a = np.asarray(angles, float)
    n = len(r)
    out = np.zeros(n, bool)
    if min_offset <= 0.0 or n < 3:
        return out
    m = float(min_offset)
    rr = np.where(np.isfinite(r) & (r > 0.0), r, np.nan)
    pad = np.full(2, np.nan)
    rp = np.concatenate([pad, rr, pad])              # rp[k + 2] = beam k
    ap = np.concatenate([a[:1] - 2 * (a[1] - a[0]), a[:1] - (a[1] - a[0]), a,
                         a[-1:] + (a[-1] - a[-2]), a[-1:] + 2 * (a[-1] - a[-2])])
    r0, rm2, rm1, rp1, rp2 = rp[2:-2], rp[:-4], rp[1:-3], rp[3:-1], rp[4:]
    a0, am2, am1, ap1, ap2 = ap[2:-2], ap[:-4], ap[1:-3], ap[3:-1], ap[4:]
    with np.errstate(invalid="ignore"):
        lo, hi = np.fmin(rm1, rp1), np.fmax(rm1, rp1)
        between = (r0 > lo + m) & (r0 < hi - m)        # NaN anywhere: False
        left = _line_range(rm2, am2, rm1, am1, a0)
        right = _line_range(rp1, ap1, rp2, ap2, a0)
        on_a_line = (np.abs(r0 - left) <= m) | (np.abs(r0 - right) <= m)
    return between & ~on_a_line


def mixed_pixel_mask_reference(ranges, angles, min_offset):
    """mixed_pixel_mask by a loop over beams with the points in the laser's plane: each
    line meets the beam's ray where the 2-D cross products say (the tests' oracle)."""
    n = len(ranges)
    out = np.zeros(n, bool)
    if min_offset <= 0.0:
        return out

    def point(k):
        if k < 0 or k >= n or not math.isfinite(ranges[k]) or ranges[k] <= 0.0:
            return None
        return np.array([ranges[k] * math.cos(angles[k]), ranges[k] * math.sin(angles[k])])

    def cross(u, v):
        return u[0] * v[1] - u[1] * v[0]

    def along_ray(p, q, d):
        """t with t * d on the line p-q, or None (parallel, or behind the laser)."""
        if p is None or q is None:
            return None
        c = cross(d, q - p)
        if abs(c) < 1e-15:
            return None
        t = cross(p, q - p) / c
        return t if t > 0.0 else None

    for i in range(n):
        p = point(i)
        prev, nxt = point(i - 1), point(i + 1)
        if p is None or prev is None or nxt is None:
            continue
        lo, hi = sorted((ranges[i - 1], ranges[i + 1]))
        if not (lo + min_offset < ranges[i] < hi - min_offset):
            continue
        d = np.array([math.cos(angles[i]), math.sin(angles[i])])
        lines = [along_ray(point(i - 2), prev, d), along_ray(nxt, point(i + 2), d)]
        out[i] = not any(t is not None and abs(ranges[i] - t) <= min_offset for t in lines)
    return out
