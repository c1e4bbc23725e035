"""Small synthetic worlds of the unit tests, built once for every package's tests.

Grids follow ROS's OccupancyGrid values (0 free, 100 occupied, -1 unknown), row 0 at
the map's origin; segment worlds are wall segments [x0, y0, x1, y1] [m] with an exact
ray caster (the oracle a scan matcher or a SLAM filter is checked against).
"""
import numpy as np

from summit_nav_common.map_io import OCCUPIED, GridMap


def square_room(size_m=20.0, resolution=0.05):
    """A square room of side size_m [m] as a GridMap at the origin: open inside, walls
    only on the map's border cells. Seen from inside, its walls meet at concave corners:
    no depth edge anywhere."""
    n = int(round(size_m / resolution))
    data = np.zeros((n, n), np.int8)
    data[[0, -1], :] = OCCUPIED
    data[:, [0, -1]] = OCCUPIED
    return GridMap(data=data, resolution=resolution, origin=(0.0, 0.0, 0.0))


def known_corridor():
    """20 x 60 cells at 0.1 m, int16: a corridor (rows 5..14) known up to column 30,
    unknown (-1) beyond; walls (100) on rows 4 and 15. Its one frontier is the corridor's
    10-cell opening at x 3.0 m; a goal just inside it lies near (2.7, 1.0) [m]."""
    g = np.full((20, 60), -1, np.int16)
    g[5:15, :30] = 0
    g[4, :30] = 100
    g[15, :30] = 100
    return g


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
