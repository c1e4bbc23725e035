"""Synthetic 2D worlds for the SLAM core tests: wall segments and an exact ray caster."""
import numpy as np

# A 10 m x 8 m room with a pillar and an L-shaped cabinet, so a scan constrains x, y, theta.
ROOM_SEGMENTS = np.array([
    # outer walls
    [-5.0, -4.0, 5.0, -4.0], [5.0, -4.0, 5.0, 4.0], [5.0, 4.0, -5.0, 4.0], [-5.0, 4.0, -5.0, -4.0],
    # pillar 0.4 m x 0.4 m at (2, 1.5)
    [1.8, 1.3, 2.2, 1.3], [2.2, 1.3, 2.2, 1.7], [2.2, 1.7, 1.8, 1.7], [1.8, 1.7, 1.8, 1.3],
    # L-shaped cabinet
    [-3.0, -2.0, -1.0, -2.0], [-1.0, -2.0, -1.0, -1.5], [-1.0, -1.5, -2.5, -1.5],
    [-2.5, -1.5, -2.5, 0.0], [-2.5, 0.0, -3.0, 0.0], [-3.0, 0.0, -3.0, -2.0],
])

N_BEAMS = 361                      # beams over 270 deg [-]
ANGLES = np.linspace(-0.75 * np.pi, 0.75 * np.pi, N_BEAMS)  # [rad]


def ray_cast(pose, angles=ANGLES, segments=ROOM_SEGMENTS, max_range=30.0):
    """Exact ranges (n,) [m] from pose (x, y, theta) to the nearest segment; inf if none."""
    x, y, th = pose
    d = np.stack((np.cos(th + angles), np.sin(th + angles)), axis=1)       # (n, 2)
    p = segments[:, :2]
    e = segments[:, 2:] - segments[:, :2]                                  # (m, 2)
    denom = d[:, None, 0] * e[None, :, 1] - d[:, None, 1] * e[None, :, 0]  # (n, m)
    qx, qy = p[None, :, 0] - x, p[None, :, 1] - y
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (qx * e[None, :, 1] - qy * e[None, :, 0]) / denom               # along the ray
        u = (qx * d[:, None, 1] - qy * d[:, None, 0]) / denom               # along the segment
    ok = (np.abs(denom) > 1e-12) & (t > 0) & (u >= 0) & (u <= 1)
    t = np.where(ok, t, np.inf).min(axis=1)
    t[t > max_range] = np.inf
    return t
