"""Removal of mixed pixels ("shadows", the veiling effect) from a laser scan.

Reference: laser_filters' ScanShadowsFilter (ROS wiki: min_angle, max_angle, window)
for the test; Tuley, Vandapel & Hebert 2005, "Analysis and removal of artifacts in 3-D
LADAR data" for why. A beam whose footprint straddles a depth edge reports a range
between the two surfaces: a point floating in free space, on the line of sight between
the edge and the background. Seen from a point p_i, its neighbour p_j then lies almost
along p_i's own beam. The test: the angle at p_i between the way back to the laser and
the segment to p_j, atan2(r_j sin(da), r_i - r_j cos(da)) for beams da apart, is below
min_angle (p_j in front, on the beam) or above pi - min_angle (behind it); both points of
such a pair are flagged. A real edge loses the one beam on each side of it,
as with laser_filters; a wall seen within min_angle of grazing goes too.

Graph SLAM's map is occupied where hits / passes exceed 0.1 (open_karto's threshold): a
floating point hits a cell that few beams cross, and one is enough to mark it. On
willow-full such dots in a corridor 1.6 m wide, inflated by the robot's radius, closed it
to the planner, and exploration ended with half the building unseen.
"""
import math

import numpy as np


def shadow_mask(ranges: np.ndarray, angles: np.ndarray, min_angle: float, window: int = 1) -> np.ndarray:
    """bool (n,): the beams of ranges (n,) [m] at angles (n,) [rad] that a neighbour up to
    `window` beams away flags as a mixed pixel (module docstring). Non-finite ranges
    (no return) flag nothing and are not flagged."""
    r = np.asarray(ranges, float)
    a = np.asarray(angles, float)
    out = np.zeros(r.shape, bool)
    if min_angle <= 0.0:
        return out
    ok = np.isfinite(r) & (r > 0.0)
    for d in range(1, int(window) + 1):
        if d >= len(r):
            break
        ri, rj = r[:-d], r[d:]
        da = a[d:] - a[:-d]
        both = ok[:-d] & ok[d:]
        with np.errstate(invalid="ignore"):
            at_i = np.abs(np.arctan2(rj * np.sin(da), ri - rj * np.cos(da)))   # the angle at p_i
            at_j = np.abs(np.arctan2(ri * np.sin(da), rj - ri * np.cos(da)))   # the angle at p_j
        bad = both & ((at_i < min_angle) | (at_i > math.pi - min_angle)
                      | (at_j < min_angle) | (at_j > math.pi - min_angle))
        out[:-d] |= bad
        out[d:] |= bad
    return out


def shadow_mask_reference(ranges, angles, min_angle, window=1):
    """shadow_mask by the obvious loop over beams and their neighbours, with the points in
    the laser's plane (the tests' oracle)."""
    n = len(ranges)
    out = np.zeros(n, bool)
    if min_angle <= 0.0:
        return out
    for i in range(n):
        for j in range(max(0, i - window), min(n, i + window + 1)):
            if j == i or not (math.isfinite(ranges[i]) and math.isfinite(ranges[j])) or ranges[i] <= 0 or ranges[j] <= 0:
                continue
            pi_ = np.array([ranges[i] * math.cos(angles[i]), ranges[i] * math.sin(angles[i])])
            pj = np.array([ranges[j] * math.cos(angles[j]), ranges[j] * math.sin(angles[j])])
            back, seg = -pi_, pj - pi_
            cos_t = float(back @ seg) / (np.linalg.norm(back) * np.linalg.norm(seg))
            t = math.acos(max(-1.0, min(1.0, cos_t)))
            if t < min_angle or t > math.pi - min_angle:
                out[i] = out[j] = True
    return out
