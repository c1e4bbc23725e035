"""Ray casting: the fast kernel against the slow traversal oracle, and rectangles."""
import math
import os

import numpy as np
import pytest

from summit_nav_common import raycast
from summit_nav_common.distance import distance_field
from summit_nav_common.map_io import OCCUPIED, GridMap, load_map

HERE = os.path.dirname(os.path.abspath(__file__))
WILLOW = os.path.join(HERE, "..", "..", "..", "data", "maps", "willow-full.yaml")  # the workspace's data/
SYNTHETIC = "synthetic"
ANGLES = np.linspace(-2.356194490192345, 2.356194490192345, 1081)


def synthetic_map(seed=3, size=(300, 400)):
    """A 0.05 m map of random boxes and thin walls (the kinds of obstacle a building has)."""
    rng = np.random.default_rng(seed)
    data = np.zeros(size, np.int8)
    for _ in range(60):
        y, x = rng.integers(0, size[0] - 20), rng.integers(0, size[1] - 20)
        h, w = (rng.integers(1, 4), rng.integers(5, 60)) if rng.random() < 0.5 else rng.integers(1, 15, 2)
        data[y:y + h, x:x + w] = OCCUPIED
    return GridMap(data=data, resolution=0.05)


def walls_of(path):
    """(grid, occupied cells with the map's border closed, distance field) of a map file,
    as the simulator sees a world."""
    grid = synthetic_map() if path == SYNTHETIC else load_map(path)
    walls = grid.data == OCCUPIED
    walls[[0, -1], :] = True
    walls[:, [0, -1]] = True
    return grid, walls, distance_field(walls)


@pytest.mark.parametrize("path", [SYNTHETIC, WILLOW])
def test_fast_matches_oracle(path):
    grid, walls, dist = walls_of(path)
    rng = np.random.default_rng(7)
    ys, xs = np.nonzero((dist > 1.0) & (grid.data == 0))  # known free space
    tmax = 30.0 / grid.resolution
    for k in rng.choice(len(xs), 12, replace=False):
        ox, oy = xs[k] + rng.random(), ys[k] + rng.random()
        ang = ANGLES + rng.uniform(-math.pi, math.pi)
        fast = raycast.cast_rays(walls, dist, ox, oy, ang, tmax)
        slow = raycast.cast_rays_reference(walls, ox, oy, ang, tmax)
        np.testing.assert_allclose(fast, slow, atol=1e-9)
        assert (fast < tmax).mean() > 0.3  # the test sees walls, not only open space


def test_known_distances_in_a_box():
    occ = np.zeros((20, 20), bool)
    occ[0, :] = occ[-1, :] = occ[:, 0] = occ[:, -1] = True
    dist = distance_field(occ)
    r = raycast.cast_rays(occ, dist, 10.0, 10.0, np.array([0.0, math.pi / 2, math.pi, -math.pi / 2]), 100.0)
    # Walls occupy cells 0 and 19: their inner faces are at 1 and 19.
    np.testing.assert_allclose(r, [9.0, 9.0, 9.0, 9.0])
    diag = raycast.cast_rays(occ, dist, 10.0, 10.0, np.array([math.pi / 4]), 100.0)
    np.testing.assert_allclose(diag, [9.0 * math.sqrt(2)])


def test_ray_leaving_the_grid_and_tmax():
    occ = np.zeros((10, 10), bool)
    dist = distance_field(occ)
    r = raycast.cast_rays(occ, dist, 5.0, 5.0, np.array([0.0, 1.0]), 50.0)
    np.testing.assert_array_equal(r, [50.0, 50.0])
    occ[5, 9] = True
    dist = distance_field(occ)
    assert raycast.cast_rays(occ, dist, 5.5, 5.5, np.array([0.0]), 2.0)[0] == 2.0


def test_rectangles_against_sampling():
    rng = np.random.default_rng(3)
    rects = np.array([[2.0, 0.5, 0.3, 0.4, 0.2], [-1.0, -2.0, -1.0, 0.3, 0.3]])
    ang = rng.uniform(-math.pi, math.pi, 400)
    got = raycast.rect_ray_distances(0.1, -0.2, ang, rects, 10.0)
    # Brute force: march 1 mm steps and test point-in-rectangle.
    t = np.arange(0, 10.0, 0.001)
    for a, g in zip(ang[:60], got[:60]):
        px, py = 0.1 + t * math.cos(a), -0.2 + t * math.sin(a)
        inside = np.zeros_like(t, bool)
        for cx, cy, yaw, hx, hy in rects:
            lx = math.cos(yaw) * (px - cx) + math.sin(yaw) * (py - cy)
            ly = -math.sin(yaw) * (px - cx) + math.cos(yaw) * (py - cy)
            inside |= (np.abs(lx) <= hx) & (np.abs(ly) <= hy)
        expect = t[np.argmax(inside)] if inside.any() else 10.0
        assert g == pytest.approx(expect, abs=0.002)


def test_ray_along_a_cell_boundary_ends(tmp_path):
    """A ray along a cell boundary (origin y exactly on a row edge, dy = -1.2e-16 from
    sin(-pi)) used to loop forever in willow-full: after a safe jump it landed in the row
    across the boundary, whose next boundary was at t = -0.0. Run in a child process so a
    regression fails on the timeout instead of hanging the suite."""
    import subprocess
    import sys
    code = (
        "import math, numpy as np\n"
        "from summit_nav_common import raycast\n"
        "from test_raycast import walls_of\n"   # python -c imports from its working directory: HERE
        f"_, occ, dist = walls_of({WILLOW!r})\n"
        "a = np.array([-math.pi, math.pi, -math.pi / 2, math.pi / 2, 0.0])\n"
        "fast = raycast.cast_rays(occ, dist, 182.5, 185.0, a, 300.0)\n"
        "ref = raycast.cast_rays_reference(occ, 182.5, 185.0, a, 300.0)\n"
        "assert np.allclose(fast, ref, atol=1e-9), (fast, ref)\n"
        "print('ok')\n")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, cwd=HERE)
    assert r.returncode == 0 and "ok" in r.stdout, r.stderr[-2000:]


def test_incidence_on_cell_edges_and_rectangle_faces():
    """grid_hit_cos_incidence: the normal of the cell edge a ray stops at; rect_ray_hits:
    the normal of the face it enters by, in the rectangle's own frame."""
    occ = np.zeros((40, 40), bool)
    occ[:, 30] = True                       # a vertical wall: cells x 30-31
    occ[5, :] = True                        # a horizontal wall: cells y 5-6
    dist = distance_field(occ)
    ang = np.radians([0.0, 30.0, -60.0, -100.0, -170.0 + 360.0])
    t = raycast.cast_rays(occ, dist, 10.5, 20.5, ang, 100.0)
    cos_inc = raycast.grid_hit_cos_incidence(10.5, 20.5, ang, t)
    # 0, 30 deg: the vertical wall (normal x); -60, -100 deg: the horizontal one (normal y);
    # 190 deg: the map's west edge is open here, nothing hit within 100 cells is not asked.
    np.testing.assert_allclose(cos_inc[:4], np.abs([1.0, math.cos(math.radians(30.0)),
                                                    math.sin(math.radians(-60.0)), math.sin(math.radians(-100.0))]))
    # A box rotated by 0.4 rad, seen head-on along its x axis and then 20 deg off it.
    rect = [(5.0, 0.0, 0.4, 1.0, 0.5)]
    ox, oy = 5.0 - 4.0 * math.cos(0.4), -4.0 * math.sin(0.4)
    d, c = raycast.rect_ray_hits(ox, oy, np.array([0.4, 0.4 + math.radians(5.0), 0.4 + math.pi]), rect, 30.0)
    assert d[0] == pytest.approx(3.0) and c[0] == pytest.approx(1.0)
    assert c[1] == pytest.approx(math.cos(math.radians(5.0)))
    assert d[2] == 30.0 and c[2] == 1.0     # looking away: nothing hit
    side = raycast.rect_ray_hits(5.0 - 3.0 * math.sin(0.4), 3.0 * math.cos(0.4), np.array([0.4 - math.pi / 2 + 0.1]),
                                 rect, 30.0)
    assert side[0][0] == pytest.approx(2.5 / math.cos(0.1)) and side[1][0] == pytest.approx(math.cos(0.1))
    np.testing.assert_array_equal(raycast.rect_ray_distances(ox, oy, np.array([0.4]), rect, 30.0), d[:1])
