"""CARMEN log reader and synthetic odometry drift, for SLAM benchmarks on real laser data.

Format: CARMEN robot log (Montemerlo, Roy, Thrun 2003, "Perspectives on standardization
in mobile robot programming: the Carnegie Mellon Navigation (CARMEN) toolkit"); the
Radish "corrected" logs keep the corrected trajectory in the FLASER pose fields, so those
poses are the reference here. Line layout:
    FLASER n r1 .. rn x y theta odom_x odom_y odom_theta ipc_timestamp hostname logger_timestamp
    PARAM robot_frontlaser_offset <x offset of the front laser [m]> host timestamp
Beams span -90 .. +90 deg; for n = 180 (or 360) beams the angular step is pi/n starting
at -90 deg, as gmapping's own CARMEN reader (carmenconfiguration.cpp) does; for n = 181
(or 361) the beams include both ends. A SICK logged in CARMEN writes "no return" as its
maximum range (81.83 m in Intel, 50 m in ACES): the largest reading of the log.

The drift model: the odometry motion model of Probabilistic Robotics (Thrun, Burgard, Fox
2005, ch. 5.4, sample_motion_model_odometry). Each reference increment is split into a
first rotation rot1, a translation trans and a second rotation rot2; each gets zero-mean
Gaussian noise with
    var(rot1)  = (rot_per_rot*rot1)^2 + (rot_per_trans*trans)^2
    var(trans) = (trans_per_trans*trans)^2 + (trans_per_rot*rot1)^2 + (trans_per_rot*rot2)^2
    var(rot2)  = (rot_per_rot*rot2)^2 + (rot_per_trans*trans)^2
(the book's alpha1..alpha4 are the squares of rot_per_rot, rot_per_trans, trans_per_trans,
trans_per_rot); rotations enter as their distance to the nearest of 0 and pi, so a step
backwards is not taken as a half turn (as amcl's odometry model does). The noisy
increments are chained from the first reference pose.
"""
import gzip
import math
import zlib
from dataclasses import dataclass

import numpy as np
from summit_nav_common.geometry import wrap_angle

# Default drift noise (std of a step's error per unit of that step's motion).
DRIFT_TRANS_PER_TRANS = 0.05   # translation error per metre driven [m/m]
DRIFT_TRANS_PER_ROT = 0.01     # translation error per radian turned [m/rad]
DRIFT_ROT_PER_TRANS = 0.03     # heading error per metre driven [rad/m]
DRIFT_ROT_PER_ROT = 0.05       # heading error per radian turned [rad/rad]
MIN_TRANS_FOR_HEADING = 1e-3   # below this step length rot1 is 0 (no direction of travel) [m]


@dataclass
class CarmenLog:
    """Laser scans of a CARMEN log. Arrays, one row per FLASER line."""
    ranges: np.ndarray      # (M, n) ranges [m]
    angles: np.ndarray      # (n,) beam angles in the laser frame [rad]
    poses: np.ndarray       # (M, 3) reference (corrected) pose x [m], y [m], theta [rad]
    timestamps: np.ndarray  # (M,) ipc timestamps [s]
    laser_offset: float = 0.0  # PARAM robot_frontlaser_offset: front laser ahead of the base [m]

    @property
    def no_return_range(self) -> float:
        """The reading the laser writes for "no return" [m]: the log's largest reading."""
        return float(np.max(self.ranges))


def beam_angles(n_beams: int) -> np.ndarray:
    """Beam angles [rad] of an n-beam CARMEN front laser spanning -90..+90 deg."""
    if n_beams <= 1:
        raise ValueError(f"a CARMEN laser needs at least 2 beams, got {n_beams}")
    if n_beams % 2 == 1:  # 181 / 361: both ends included
        return np.linspace(-math.pi / 2.0, math.pi / 2.0, n_beams)
    return -math.pi / 2.0 + np.arange(n_beams) * (math.pi / n_beams)


def read_carmen(path: str) -> CarmenLog:
    """Read the FLASER lines of a CARMEN log (plain or .gz) into a CarmenLog.

    Raises FileNotFoundError for a missing file, ValueError naming the file on a file that
    is not a readable CARMEN log (a truncated or corrupt gzip, binary data, no FLASER
    line), on a malformed FLASER line, or when the beam count changes within the log.
    """
    opener = gzip.open if path.endswith(".gz") else open
    ranges, poses, stamps = [], [], []
    n_beams = None
    laser_offset = 0.0
    try:
        with opener(path, "rt") as f:
            for line_no, line in enumerate(f, 1):
                if line.startswith("PARAM robot_frontlaser_offset"):
                    laser_offset = _param_float(path, line_no, line)
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
    except (EOFError, gzip.BadGzipFile, UnicodeDecodeError, zlib.error) as exc:
        raise ValueError(f"{path}: not a readable CARMEN log ({type(exc).__name__}: {exc})") from exc
    if not ranges:
        raise ValueError(f"{path}: no FLASER lines (not a CARMEN laser log?)")
    return CarmenLog(ranges=np.vstack(ranges), angles=beam_angles(n_beams),
                     poses=np.asarray(poses, dtype=float), timestamps=np.asarray(stamps),
                     laser_offset=laser_offset)


def _param_float(path, line_no, line):
    try:
        return float(line.split()[2])
    except (ValueError, IndexError) as exc:
        raise ValueError(f"{path}:{line_no}: malformed PARAM line ({exc})") from exc


def monotonic_stamps(timestamps: np.ndarray, min_gap: float) -> np.ndarray:
    """Timestamps (M,) [s] made strictly increasing: each one at least min_gap [s] after
    the one before (a few FLASER lines of the Intel log go back in time by up to 0.86 s)."""
    out = np.asarray(timestamps, float).copy()
    for k in range(1, len(out)):
        out[k] = max(out[k], out[k - 1] + min_gap)
    return out


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

    Probabilistic Robotics' odometry model (module docstring): every reference increment
    as rot1 / trans / rot2, each with independent Gaussian noise; the odometry starts at
    the first reference pose. `rng` is the (seeded) numpy Generator that draws the noise,
    three standard normals per increment in the order rot1, trans, rot2.
    """
    poses = np.asarray(poses, dtype=float)
    inc = relative_increments(poses)
    trans = np.hypot(inc[:, 0], inc[:, 1])
    moved = trans > MIN_TRANS_FOR_HEADING
    rot1 = np.where(moved, np.arctan2(inc[:, 1], inc[:, 0]), 0.0)
    rot2 = wrap_angle(inc[:, 2] - rot1)
    r1, r2 = _to_zero_or_pi(rot1), _to_zero_or_pi(rot2)
    std_rot1 = np.hypot(rot_per_rot * r1, rot_per_trans * trans)
    std_trans = np.sqrt((trans_per_trans * trans) ** 2 + (trans_per_rot * r1) ** 2
                        + (trans_per_rot * r2) ** 2)
    std_rot2 = np.hypot(rot_per_rot * r2, rot_per_trans * trans)
    z = rng.standard_normal((len(inc), 3))
    n_rot1 = rot1 + z[:, 0] * std_rot1
    n_trans = trans + z[:, 1] * std_trans
    n_rot2 = rot2 + z[:, 2] * std_rot2
    noisy = np.column_stack((n_trans * np.cos(n_rot1), n_trans * np.sin(n_rot1),
                             wrap_angle(n_rot1 + n_rot2)))
    return chain_increments(poses[0], noisy)


def _to_zero_or_pi(angle: np.ndarray) -> np.ndarray:
    """|angle| [rad] measured to the nearest of 0 and pi (a step backwards turns by ~0)."""
    a = np.abs(wrap_angle(angle))
    return np.minimum(a, math.pi - a)
