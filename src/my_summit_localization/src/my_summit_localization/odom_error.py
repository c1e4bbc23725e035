"""Odometry against ground truth, with no alignment: the error a robot's odom frame has.

The odom frame starts at the robot's start pose, so the truth is taken relative to its
first sample (the start) and compared, sample by sample, with an odometry estimate
(raw wheel odometry or the EKF's): absolute trajectory error (ATE, the RMS of the
position error over the run, Sturm et al. 2012 without their alignment step), and the
heading and position error at the end. Poses are (t [s], x [m], y [m], yaw [rad]) rows.
"""
from dataclasses import dataclass

import numpy as np

from summit_nav_common.geometry import relative, wrap_angle


@dataclass
class OdomError:
    ate: float              # [m] RMS position error over the run
    final_position: float   # [m] position error at the last estimate
    final_heading: float    # [rad] |heading error| at the last estimate
    max_heading: float      # [rad] largest |heading error| over the run
    samples: int


def truth_in_odom(truth):
    """Truth rows (t, x, y, yaw) in the world, re-expressed relative to the first one."""
    truth = np.asarray(truth, dtype=np.float64)
    rel = relative(truth[0, 1:4], truth[:, 1:4])
    return np.column_stack([truth[:, 0], rel])


def interpolate(track, times):
    """track rows (t, x, y, yaw) at `times` [s] (linear; yaw unwrapped first), clipped
    to the track's span."""
    track = np.asarray(track, dtype=np.float64)
    yaw = np.unwrap(track[:, 3])
    return np.column_stack([times, np.interp(times, track[:, 0], track[:, 1]),
                            np.interp(times, track[:, 0], track[:, 2]),
                            wrap_angle(np.interp(times, track[:, 0], yaw))])


def odom_error(estimate, truth, t_end=None):
    """OdomError of estimate rows (t, x, y, yaw) in the odom frame against world truth
    rows (t, x, y, yaw), over the estimate's samples within the truth's time span (and
    not after t_end [s] when given)."""
    est = np.asarray(estimate, dtype=np.float64)
    ref = truth_in_odom(truth)
    keep = (est[:, 0] >= ref[0, 0]) & (est[:, 0] <= ref[-1, 0])
    if t_end is not None:
        keep &= est[:, 0] <= t_end
    est = est[keep]
    if len(est) == 0:
        raise ValueError("no estimate within the ground truth's time span")
    at = interpolate(ref, est[:, 0])
    d = np.hypot(est[:, 1] - at[:, 1], est[:, 2] - at[:, 2])
    h = np.abs(wrap_angle(est[:, 3] - at[:, 3]))
    return OdomError(float(np.sqrt(np.mean(d * d))), float(d[-1]), float(h[-1]), float(h.max()), len(est))
