"""gmapping's odometry sampling motion model, vectorized over all particles.

Reference: GMapping's MotionModel::drawFromMotion (openslam_gmapping,
gridfastslam/motionmodel.cpp), used by Grisetti, Stachniss, Burgard 2007, "Improved
Techniques for Grid Mapping with Rao-Blackwellized Particle Filters", IEEE T-RO 23(1).

The odometry increment between two odometry poses is taken in the old pose's frame
(absoluteDifference), each component gets zero-mean Gaussian noise whose std grows with
the motion, and the noisy increment is composed onto every particle (absoluteSum):
    std_x  = srr*|dx| + str*|dtheta| + SXY_FACTOR*srr*|dy|
    std_y  = srr*|dy| + str*|dtheta| + SXY_FACTOR*srr*|dx|
    std_th = stt*|dtheta| + srt*sqrt(dx^2 + dy^2)
(srt/str with the code's meaning; see slam_config.py.)
"""
import numpy as np

from summit_nav_common.geometry import compose

SXY_FACTOR = 0.3  # cross-coupling of lateral noise, gmapping's "sxy = 0.3*srr" [-]


def odometry_increment(old_pose: np.ndarray, new_pose: np.ndarray) -> np.ndarray:
    """Increment (3,) [m, m, rad] from odometry pose old to new, in old's frame."""
    dx, dy = new_pose[0] - old_pose[0], new_pose[1] - old_pose[1]
    c, s = np.cos(old_pose[2]), np.sin(old_pose[2])
    dth = np.arctan2(np.sin(new_pose[2] - old_pose[2]), np.cos(new_pose[2] - old_pose[2]))
    return np.array([c * dx + s * dy, -s * dx + c * dy, dth])


def noise_std(increment: np.ndarray, srr: float, srt: float, str_: float, stt: float) -> np.ndarray:
    """Std (3,) [m, m, rad] of the increment's noise per gmapping's model."""
    dx, dy, dth = np.abs(increment)
    sxy = SXY_FACTOR * srr
    return np.array([srr * dx + str_ * dth + sxy * dy,
                     srr * dy + str_ * dth + sxy * dx,
                     stt * dth + srt * np.hypot(dx, dy)])


def sample_motion(poses: np.ndarray, old_odom: np.ndarray, new_odom: np.ndarray,
                  srr: float, srt: float, str_: float, stt: float,
                  rng: np.random.Generator, out: np.ndarray = None) -> np.ndarray:
    """Move all particles (N, 3) [m, m, rad] by the odometry change old_odom -> new_odom.

    Each particle gets its own noisy copy of the increment. Returns the new (N, 3)
    poses (written into `out` when given, which may be `poses` itself).
    """
    inc = odometry_increment(np.asarray(old_odom, float), np.asarray(new_odom, float))
    std = noise_std(inc, srr, srt, str_, stt)
    noisy = inc + rng.standard_normal((poses.shape[0], 3)) * std
    return compose(poses, noisy, out=out)
