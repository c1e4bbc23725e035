"""CARMEN log reader and synthetic odometry drift, for offline SLAM benchmarks.

Format: CARMEN robot log (Montemerlo, Roy, Thrun 2003, "Perspectives on standardization
in mobile robot programming: the Carnegie Mellon Navigation (CARMEN) toolkit"); the
Radish "corrected" logs keep the corrected trajectory in the FLASER pose fields, so those
poses are the reference here. Line layout:
    FLASER n r1 .. rn x y theta odom_x odom_y odom_theta ipc_timestamp hostname logger_timestamp
Beams span -90 .. +90 deg; for n = 180 (or 360) beams the angular step is pi/n starting
at -90 deg, as gmapping's own CARMEN reader (carmenconfiguration.cpp) does; for n = 181
(or 361) the beams include both ends.

The drift model: each reference increment (in the previous pose's frame) gets Gaussian
noise whose std grows with the step's translation and rotation (the usual odometry error
model, Probabilistic Robotics ch. 5.4), then the noisy increments are chained.
"""
import gzip
import math
from dataclasses import dataclass

import numpy as np
from summit_nav_common.geometry import wrap_angle

# Default drift noise (std of a step's error per unit of that step's motion).
DRIFT_TRANS_PER_TRANS = 0.05   # translation error per metre driven [m/m]
DRIFT_TRANS_PER_ROT = 0.01     # translation error per radian turned [m/rad]
DRIFT_ROT_PER_TRANS = 0.03     # heading error per metre driven [rad/m]
DRIFT_ROT_PER_ROT = 0.05       # heading error per radian turned [rad/rad]


@dataclass
class CarmenLog:
    """Laser scans of a CARMEN log. Arrays, one row per FLASER line."""
    ranges: np.ndarray      # (M, n) ranges [m]
    angles: np.ndarray      # (n,) beam angles in the laser frame [rad]
    poses: np.ndarray       # (M, 3) reference (corrected) pose x [m], y [m], theta [rad]
    timestamps: np.ndarray  # (M,) ipc timestamps [s]


def beam_angles(n_beams: int) -> np.ndarray:
    """Beam angles [rad] of an n-beam CARMEN front laser spanning -90..+90 deg."""
    if n_beams <= 1:
        raise ValueError(f"a CARMEN laser needs at least 2 beams, got {n_beams}")
    if n_beams % 2 == 1:  # 181 / 361: both ends included
        return np.linspace(-math.pi / 2.0, math.pi / 2.0, n_beams)
    return -math.pi / 2.0 + np.arange(n_beams) * (math.pi / n_beams)


def read_carmen(path: str) -> CarmenLog:
    """Read the FLASER lines of a CARMEN log (plain or .gz) into a CarmenLog.

    Raises ValueError on a malformed FLASER line or a log without FLASER lines, or when
    the beam count changes within the log.
    """
    opener = gzip.open if path.endswith(".gz") else open
    ranges, poses, stamps = [], [], []
    n_beams = None
    with opener(path, "rt") as f:
        for line_no, line in enumerate(f, 1):
            if not line.startswith("FLASER"):
                continue
            tok = line.split()
            try:
                n = int(tok[1])
                r = np.array(tok[2:2 + n], dtype=float)
                x, y, th = (float(v) for v in tok[2 + n:5 + n])
                stamp = float(tok[8 + n])
            except (ValueError, IndexError) as exc:
                raise ValueError(f"{path}:{line_no}: malformed FLASER line ({exc})") from exc
            if r.size != n:
                raise ValueError(f"{path}:{line_no}: FLASER announces {n} beams, has {r.size}")
            if n_beams is None:
                n_beams = n
            elif n != n_beams:
                raise ValueError(f"{path}:{line_no}: beam count changed from {n_beams} to {n}")
            ranges.append(r)
            poses.append((x, y, th))
            stamps.append(stamp)
    if not ranges:
        raise ValueError(f"{path}: no FLASER lines")
    return CarmenLog(ranges=np.vstack(ranges), angles=beam_angles(n_beams),
                     poses=np.asarray(poses, dtype=float), timestamps=np.asarray(stamps))


def relative_increments(poses: np.ndarray) -> np.ndarray:
    """Pose increments (M-1, 3) [m, m, rad], each in the frame of the earlier pose."""
    d = np.diff(poses, axis=0)
    c, s = np.cos(poses[:-1, 2]), np.sin(poses[:-1, 2])
    return np.column_stack((c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1],
                            wrap_angle(d[:, 2])))


def chain_increments(start: np.ndarray, increments: np.ndarray) -> np.ndarray:
    """Compose a start pose (3,) with (K, 3) local increments; returns (K+1, 3) poses."""
    out = np.empty((len(increments) + 1, 3))
    out[0] = start
    x, y, th = (float(v) for v in start)
    for k, (dx, dy, dth) in enumerate(increments, 1):
        c, s = math.cos(th), math.sin(th)
        x, y = x + c * dx - s * dy, y + s * dx + c * dy
        th = math.atan2(math.sin(th + dth), math.cos(th + dth))
        out[k] = (x, y, th)
    return out


def make_drifted_odometry(poses: np.ndarray, rng: np.random.Generator,
                          trans_per_trans: float = DRIFT_TRANS_PER_TRANS,
                          trans_per_rot: float = DRIFT_TRANS_PER_ROT,
                          rot_per_trans: float = DRIFT_ROT_PER_TRANS,
                          rot_per_rot: float = DRIFT_ROT_PER_ROT) -> np.ndarray:
    """Odometry (M, 3) [m, m, rad] drifting from the reference `poses` (M, 3).

    Each reference increment gets independent Gaussian noise with
    std_xy = trans_per_trans*|d| + trans_per_rot*|dtheta| and
    std_theta = rot_per_rot*|dtheta| + rot_per_trans*|d|; the odometry starts at the
    first reference pose. `rng` is the (seeded) numpy Generator that draws the noise.
    """
    poses = np.asarray(poses, dtype=float)
    inc = relative_increments(poses)
    dist = np.hypot(inc[:, 0], inc[:, 1])
    rot = np.abs(inc[:, 2])
    std_xy = trans_per_trans * dist + trans_per_rot * rot
    std_th = rot_per_rot * rot + rot_per_trans * dist
    noisy = inc.copy()
    noisy[:, 0] += rng.standard_normal(len(inc)) * std_xy
    noisy[:, 1] += rng.standard_normal(len(inc)) * std_xy
    noisy[:, 2] += rng.standard_normal(len(inc)) * std_th
    return chain_increments(poses[0], noisy)


