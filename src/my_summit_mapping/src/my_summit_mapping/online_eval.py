"""Online trajectory of a live SLAM node from its map -> odom tf, and its filter updates.

A live gmapping-style node publishes map -> odom; its pose estimate for a scan, as a user
of the map frame sees it while the robot drives, is map -> odom composed with that scan's
odometry. Here, for scan k the map -> odom used is the last one broadcast with a stamp
before the next scan's stamp: when the node keeps up, the one computed by the latest
filter update at or before scan k; a node that falls behind is judged on an older one,
as a user of it would be. Before the first broadcast map -> odom is the identity (as
gmapping's). The online trajectory is then scored with metrics.ate_rmse (RMSE after the
best rigid 2D alignment, Umeyama) against the reference poses of the same scans.

Filter updates are counted from the broadcasts: every update after the first moves the
best particle against the odometry, so map -> odom changes; the first one (the filter's
initialization on the first scan) leaves it at the identity. The expected number follows
gmapping's gate (GridSlamProcessor::processScan): the first scan, then every scan after
which the odometry has travelled >= linearUpdate or turned >= angularUpdate since the
last update (temporalUpdate off, as by default).

Where the error comes from (error_series, step_errors, update_delays): the per-scan
position and heading error after that same alignment, the error of each step's pose
increment in the reference step's frame (along track, across, heading: a jump when the
best particle changes or a loop closes, a slow drift, the scan matcher's step noise
against the odometry's), and how long after a scan its map -> odom changed (a node
that lags judged on older corrections).
"""
from typing import Tuple

import numpy as np
from summit_nav_common.geometry import wrap_angle

from . import metrics
from .motion_model import odometry_increment

CHANGE_TOL = 1e-9  # map -> odom components closer than this count as unchanged [m, rad]


def compose(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """SE(2) product a * b of poses (K, 3) or (3,) [m, m, rad], row by row."""
    a, b = np.atleast_2d(a), np.atleast_2d(b)
    c, s = np.cos(a[:, 2]), np.sin(a[:, 2])
    th = a[:, 2] + b[:, 2]
    return np.column_stack((a[:, 0] + c * b[:, 0] - s * b[:, 1], a[:, 1] + s * b[:, 0] + c * b[:, 1],
                            np.arctan2(np.sin(th), np.cos(th))))


def map_to_odom_at_scans(scan_stamps: np.ndarray, tf_stamps: np.ndarray, tf_values: np.ndarray) -> np.ndarray:
    """map -> odom (K, 3) in effect for each scan: the last broadcast (tf_stamps (T,)
    ascending, tf_values (T, 3)) stamped before the next scan's stamp (any, for the last
    scan); the identity when there is none."""
    scan_stamps = np.asarray(scan_stamps, float)
    tf_stamps = np.asarray(tf_stamps, float)
    ends = np.append(scan_stamps[1:], np.inf)
    idx = np.searchsorted(tf_stamps, ends, side="left") - 1   # last stamp < end
    values = np.vstack((np.zeros((1, 3)), np.asarray(tf_values, float).reshape(-1, 3)))
    return values[idx + 1]


def online_trajectory(scan_stamps, odometry, tf_stamps, tf_values) -> np.ndarray:
    """The node's online pose estimate (K, 3) at each scan: map_to_odom_at_scans * odometry."""
    return compose(map_to_odom_at_scans(scan_stamps, tf_stamps, tf_values), np.asarray(odometry, float))


def online_ate(scan_stamps, odometry, reference, tf_stamps, tf_values) -> Tuple[float, np.ndarray]:
    """(ATE RMSE [m] of the online trajectory against reference (K, 3), the trajectory)."""
    traj = online_trajectory(scan_stamps, odometry, tf_stamps, tf_values)
    return metrics.ate_rmse(traj, reference), traj


def error_series(estimate: np.ndarray, reference: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
    """Per-pose error of estimate (K, 3) against reference (K, 3) after the best rigid 2D
    alignment of the positions (as ate_rmse): (position error vectors (K, 2) [m] in the
    reference frame, heading error (K,) [rad] wrapped to [-pi, pi))."""
    est, ref = np.asarray(estimate, float), np.asarray(reference, float)
    rot, t = metrics.rigid_alignment_2d(est, ref)
    err = est[:, :2] @ rot.T + t - ref[:, :2]
    heading = est[:, 2] + np.arctan2(rot[1, 0], rot[0, 0]) - ref[:, 2]
    return err, wrap_angle(heading)


def step_errors(estimate: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """Error (K-1, 3) of each step's increment (along [m], across [m], heading [rad]):
    the estimate's increment from pose k to k+1 minus the reference's, both taken in
    their own pose k's frame (odometry_increment). Independent of any alignment."""
    est, ref = np.asarray(estimate, float), np.asarray(reference, float)
    out = np.empty((max(len(est) - 1, 0), 3))
    for k in range(len(out)):
        out[k] = odometry_increment(est[k], est[k + 1]) - odometry_increment(ref[k], ref[k + 1])
    out[:, 2] = wrap_angle(out[:, 2])
    return out


def update_delays(scan_stamps: np.ndarray, tf_stamps: np.ndarray,
                  tf_values: np.ndarray, tol: float = CHANGE_TOL) -> Tuple[np.ndarray, np.ndarray]:
    """When map -> odom changed relative to the scans: (delay (U,) [s] of each change
    (tf_stamps (T,) ascending, tf_values (T, 3); the first change from the identity
    included) after the last scan stamped at or before it, changes (K,) per scan).
    Changes before the first scan are left out."""
    scans = np.asarray(scan_stamps, float)
    t = np.asarray(tf_stamps, float)
    v = np.asarray(tf_values, float).reshape(-1, 3)
    prev = np.vstack((np.zeros((1, 3)), v[:-1]))
    changed = t[np.any(np.abs(v - prev) > tol, axis=1)]
    k = np.searchsorted(scans, changed, side="right") - 1
    keep = k >= 0
    return changed[keep] - scans[k[keep]], np.bincount(k[keep], minlength=len(scans))


def count_updates(tf_values: np.ndarray, tol: float = CHANGE_TOL) -> int:
    """Filter updates seen in a sequence of map -> odom broadcasts (T, 3): the changes
    between consecutive values (the identity before the first), plus the initialization.
    0 when nothing was broadcast."""
    v = np.asarray(tf_values, float).reshape(-1, 3)
    if len(v) == 0:
        return 0
    prev = np.vstack((np.zeros((1, 3)), v[:-1]))
    return 1 + int(np.sum(np.any(np.abs(v - prev) > tol, axis=1)))


def expected_updates(odometry: np.ndarray, linear_update: float, angular_update: float) -> int:
    """Scans gmapping's gate lets through on the odometry poses (K, 3) of the scans."""
    odom = np.asarray(odometry, float)
    if len(odom) == 0:
        return 0
    count, lin, ang = 1, 0.0, 0.0
    for k in range(1, len(odom)):
        inc = odometry_increment(odom[k - 1], odom[k])
        lin += float(np.hypot(inc[0], inc[1]))
        ang += abs(float(inc[2]))
        if lin >= linear_update or ang >= angular_update:
            count, lin, ang = count + 1, 0.0, 0.0
    return count
