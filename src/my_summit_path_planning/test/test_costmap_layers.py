"""Costmap2D, layers and the cost translation table, against costmap_2d's documented behaviour."""
import math

import numpy as np
import numpy.testing as npt
import pytest

from my_summit_path_planning import cost_values as cv
from my_summit_path_planning.costmap import Costmap2D, CostmapError, Footprint, LayeredCostmap
from my_summit_path_planning.layers import (ObstacleLayer, cells_inside_convex, cloud_to_observation,
                                            inflation_cost, ray_cells, ray_cells_continuous, raytrace_reference,
                                            scan_to_observation, SUPERSAMPLE)
from summit_nav_common.grid_kernels import fill_rays

SUMMIT_FOOTPRINT = [[0.36, 0.31], [-0.36, 0.31], [-0.36, -0.31], [0.36, -0.31]]


def test_translation_table():
    t = cv.COST_TRANSLATION_TABLE
    assert (t[0], t[253], t[254], t[255]) == (0, 99, 100, -1)
    assert t[1] == 1 and t[252] == 98
    assert np.all(np.diff(t[1:253].astype(int)) >= 0)
    with pytest.raises(TypeError):
        cv.costs_to_occupancy(np.zeros(3, np.int32))


def test_world_map_round_trip_and_bounds():
    c = Costmap2D(10, 5, 0.1, -1.0, 2.0)
    assert c.world_to_map(-1.0, 2.0) == (0, 0)
    assert c.world_to_map(-0.01, 2.49) == (9, 4)
    assert c.world_to_map(0.0, 2.0) is None and c.world_to_map(-1.01, 2.0) is None
    assert c.world_to_map(float("nan"), 2.0) is None
    npt.assert_allclose(c.map_to_world(3, 2), (-0.65, 2.25))
    assert c.get_cost(10, 0) is None


def test_footprint_radii_and_padding():
    fp = Footprint.from_params(SUMMIT_FOOTPRINT)
    assert fp.inscribed_radius == pytest.approx(0.31)
    assert fp.circumscribed_radius == pytest.approx(math.hypot(0.36, 0.31))
    padded = Footprint.from_params(SUMMIT_FOOTPRINT, padding=0.05)
    assert padded.inscribed_radius == pytest.approx(0.36)
    r = Footprint.from_params(None, robot_radius=0.3)
    assert r.inscribed_radius == r.circumscribed_radius == 0.3
    centres, radius = fp.covering_circles()
    # Every footprint point lies inside some covering circle.
    xs, ys = np.meshgrid(np.linspace(-0.36, 0.36, 30), np.linspace(-0.31, 0.31, 30))
    pts = np.column_stack([xs.ravel(), ys.ravel()])
    d = np.hypot(pts[:, None, 0] - centres[None, :, 0], pts[:, None, 1] - centres[None, :, 1]).min(axis=1)
    assert (d <= radius + 1e-9).all()
    with pytest.raises(CostmapError):
        Footprint.from_params([[0, 0], [1, 1]])


def test_static_layer_values(footprint, make_static_costmap):
    static_costmap = make_static_costmap
    occ = np.zeros((40, 40), np.int8)
    occ[0:5, 0:5] = -1
    occ[20, 20] = 100
    lc = static_costmap(occ, footprint)
    d = lc.master.data
    assert d[2, 2] == cv.NO_INFORMATION and d[20, 20] == cv.LETHAL_OBSTACLE and d[39, 39] == cv.FREE_SPACE
    lc2 = static_costmap(occ, footprint, track_unknown=False)
    assert lc2.master.data[2, 2] == cv.FREE_SPACE


def test_inflation_profile_matches_formula(footprint, make_static_costmap):
    static_costmap = make_static_costmap
    res, csf, radius = 0.05, 10.0, 0.55
    occ = np.zeros((61, 61), np.int8)
    occ[30, 30] = 100
    lc = static_costmap(occ, footprint, res, inflation={"inflation_radius": radius, "cost_scaling_factor": csf})
    d = lc.master.data
    yy, xx = np.mgrid[0:61, 0:61]
    dist = np.hypot(xx - 30, yy - 30) * res
    expect = np.where(dist == 0, 254, np.where(dist <= 0.31, 253,
                      np.floor(252 * np.exp(-csf * (dist - 0.31)))))
    expect = np.where(dist > math.ceil(radius / res) * res + 1e-9, 0, expect)
    npt.assert_array_equal(d, expect.astype(np.uint8))
    assert inflation_cost(0.0, 0.31, csf) == 254
    assert inflation_cost(0.31, 0.31, csf) == 253
    assert inflation_cost(0.36, 0.31, csf) == int(252 * math.exp(-csf * 0.05))


def test_raycells_match_bresenham():
    rng = np.random.default_rng(3)
    ends = rng.integers(-30, 30, size=(200, 2))
    ray, cx, cy = ray_cells(0, 0, ends[:, 0], ends[:, 1])
    for i, (ex, ey) in enumerate(ends):
        got = list(zip(cx[ray == i].tolist(), cy[ray == i].tolist()))
        ref = raytrace_reference(0, 0, int(ex), int(ey))
        assert got[0] == ref[0] and got[-1] == ref[-1] and len(got) == len(ref)
        # Same cells up to rounding at exact ties: never more than one cell apart.
        assert max(max(abs(a[0] - b[0]), abs(a[1] - b[1])) for a, b in zip(got, ref)) <= 1


def _local(footprint, size=80, res=0.05):
    params = {"obstacle_layer": {"observation_sources": "scan", "scan": {"clearing": True},
                                 "obstacle_range": 2.5, "raytrace_range": 3.0}}
    lc = LayeredCostmap.from_plugins([{"name": "obstacle_layer", "type": "costmap_2d::ObstacleLayer"}],
                                     params, Costmap2D(size, size, res), footprint, rolling_window=True)
    return lc


@pytest.mark.parametrize("seed", range(4))
def test_compiled_ray_clearing_sets_the_cells_of_its_numpy_oracle(seed):
    """fill_rays (csrc/raytrace.c) replaced ray_cells_continuous in the obstacle layer's
    clearing: the NumPy walk held several int64 arrays of every cell of 1081 rays at once,
    move_base's largest transient (issue 43). Same cells, from origins inside and outside
    the grid, ends off it, rays along cell boundaries, zero-length and non-finite rays."""
    rng = np.random.default_rng(seed)
    h, w = 60, 80
    for x0, y0 in [(rng.uniform(0, w), rng.uniform(0, h)), (40.0, 30.0), (-5.5, 12.25), (10.0, 10.0)]:
        ends = np.concatenate([rng.uniform(-20, 100, (300, 2)), [[x0, y0], [x0 + 7, y0], [x0, y0 - 9.0],
                                                                 [x0 + 3, y0 + 3]]])
        ex, ey = ends[:, 0].copy(), ends[:, 1].copy()
        expected = np.zeros((h, w), np.uint8)
        _, cx, cy = ray_cells_continuous(x0, y0, ex, ey)
        inside = (cx >= 0) & (cy >= 0) & (cx < w) & (cy < h)
        expected[cy[inside], cx[inside]] = 7
        got = np.zeros((h, w), np.uint8)
        fill_rays(got, x0, y0, ex, ey, SUPERSAMPLE, 7)
        npt.assert_array_equal(got, expected)
    grid = np.zeros((h, w), np.uint8)
    fill_rays(grid, 5.0, 5.0, [np.nan, np.inf], [1.0, 2.0], SUPERSAMPLE, 7)
    assert not grid.any()
    with pytest.raises(ValueError, match="uint8"):
        fill_rays(np.zeros((h, w), np.int16), 5.0, 5.0, [1.0], [1.0], SUPERSAMPLE, 7)


def test_obstacle_layer_marks_and_clears(footprint):
    lc = _local(footprint)
    layer = lc.layer("obstacle_layer")
    ranges = np.full(9, 1.5)
    obs = scan_to_observation(ranges, -0.4, 0.1, 0.1, 30.0, (0.0, 0.0, 0.0))
    layer.add_observation(obs)
    lc.update_map(0.0, 0.0, 0.0)
    assert lc.master.cost_at(1.52, 0.0) == cv.LETHAL_OBSTACLE
    # The obstacle moves away: the next scan clears the old cell.
    layer.add_observation(scan_to_observation(np.full(9, 1.9), -0.4, 0.1, 0.1, 30.0, (0.0, 0.0, 0.0)))
    lc.update_map(0.0, 0.0, 0.0)
    assert lc.master.cost_at(1.52, 0.0) == cv.FREE_SPACE
    assert lc.master.cost_at(1.92, 0.0) == cv.LETHAL_OBSTACLE


@pytest.mark.parametrize("kind", ["obstacle", "voxel"])
def test_a_cloud_marks_by_each_point_height_and_clears_along_its_rays(footprint, kind):
    """costmap_2d's rules for a PointCloud(2) source: the observation buffer keeps only points
    within the source's [min_obstacle_height, max_obstacle_height] (for clearing too); the
    layer marks a kept point nearer the sensor than obstacle_range in 3D and not above its
    own max_obstacle_height (a voxel layer: nor at or above its grid's top); every kept
    point clears along its ray on the ground."""
    ltype = {"obstacle": "costmap_2d::ObstacleLayer", "voxel": "costmap_2d::VoxelLayer"}[kind]
    params = {"o": {"observation_sources": "cam", "max_obstacle_height": 1.2,
                    "cam": {"data_type": "PointCloud2", "clearing": True, "min_obstacle_height": 0.1,
                            "max_obstacle_height": 1.6, "obstacle_range": 2.5}}}
    if kind == "voxel":
        params["o"].update(origin_z=0.0, z_resolution=0.2, z_voxels=5)      # the grid's top at 1.0 m
    lc = LayeredCostmap.from_plugins([{"name": "o", "type": ltype}], params, Costmap2D(120, 120, 0.05, -3.0, -3.0),
                                     footprint, rolling_window=True)
    layer = lc.layer("o")
    origin = (0.0, 0.0, 0.5)                     # a camera 0.5 m up
    pts = [(1.5, 0.0, 0.3),                      # marks
           (0.0, 1.5, 0.05),                     # below the source's band: dropped
           (0.0, -1.5, 1.1),                     # in the band, above the voxel grid's top
           (-1.5, 0.0, 1.4),                     # in the band, above the layer's max_obstacle_height
           (1.0, 1.0, 0.9),                      # marks (in both)
           (2.4, -0.5, 1.05),                    # 2.45 m on the ground, 2.51 m in 3D: too far to mark
           (float("nan"), 0.0, 0.3)]
    obs = cloud_to_observation(pts, origin, 2.5, 3.0, True, True, 0.1, 1.6, "cam")
    assert len(obs.points) == 5                  # NaN and the low point dropped
    layer.add_observation(obs)
    lc.update_map(0.0, 0.0, 0.0)
    cost = lambda x, y: lc.master.cost_at(x, y)  # noqa: E731
    assert cost(1.5, 0.0) == cv.LETHAL_OBSTACLE and cost(1.0, 1.0) == cv.LETHAL_OBSTACLE
    assert cost(0.0, 1.5) == cv.FREE_SPACE and cost(-1.5, 0.0) == cv.FREE_SPACE
    assert cost(0.0, -1.5) == (cv.LETHAL_OBSTACLE if kind == "obstacle" else cv.FREE_SPACE)
    assert cost(2.4, -0.5) == cv.FREE_SPACE
    # The next cloud sees further along the first ray: that clears the old hit.
    layer.add_observation(cloud_to_observation([(2.0, 0.0, 0.3)], origin, 2.5, 3.0, True, True, 0.1, 1.6, "cam"))
    lc.update_map(0.0, 0.0, 0.0)
    assert cost(1.5, 0.0) == cv.FREE_SPACE and cost(2.0, 0.0) == cv.LETHAL_OBSTACLE


@pytest.mark.parametrize("padding", [0.0, 0.02])
def test_footprint_clearing_keeps_cells_the_outline_only_grazes(padding):
    fp = Footprint.from_params(SUMMIT_FOOTPRINT, padding=padding)
    lc = _local(fp)
    layer = lc.layer("obstacle_layer")
    lc.update_map(0.0, 0.0, 0.0)
    g = layer.grid
    # Cells (by centre): under the body; wholly under it, next to the left side; a
    # wall cell the unpadded side (y = 0.31 m) cuts through; one just outside it.
    cells = {"centre": (0.025, 0.025), "inner": (0.125, 0.275), "grazed": (0.125, 0.325),
             "outside": (0.125, 0.375)}
    for x, y in cells.values():
        mx, my = g.world_to_map(x, y)
        g.data[my, mx] = cv.LETHAL_OBSTACLE
    lc.update_map(0.0, 0.0, 0.0)
    got = {k: lc.master.cost_at(x, y) for k, (x, y) in cells.items()}
    assert got["centre"] == cv.FREE_SPACE and got["inner"] == cv.FREE_SPACE
    assert got["grazed"] == cv.LETHAL_OBSTACLE and got["outside"] == cv.LETHAL_OBSTACLE


def test_cells_inside_convex_either_winding():
    g = Costmap2D(20, 20, 0.1, 0.0, 0.0)
    square = np.array([[0.5, 0.5], [1.5, 0.5], [1.5, 1.5], [0.5, 1.5]])  # 10 x 10 cells
    for poly in (square, square[::-1]):
        my, mx = cells_inside_convex(poly, g, 0.0)
        assert len(my) == 100 and mx.min() == 5 and mx.max() == 14
        my, mx = cells_inside_convex(poly, g, 0.1)  # one cell row in from every side
        assert len(my) == 64 and my.min() == 6 and my.max() == 13
        my, mx = cells_inside_convex(poly, g, 0.0, whole_cells=True)  # squares on the grid
        assert len(my) == 100
        my, mx = cells_inside_convex(poly + 0.01, g, 0.0, whole_cells=True)  # shifted off it
        assert len(my) == 81 and mx.min() == 6 and my.max() == 14
    # A diamond: a cell square pokes out by half its diagonal, its centre a cell in.
    diamond = np.array([[1.0, 0.4], [1.6, 1.0], [1.0, 1.6], [0.4, 1.0]])
    ctr = cells_inside_convex(diamond, g, 0.0)
    whole = cells_inside_convex(diamond, g, 0.0, whole_cells=True)
    assert len(whole[0]) < len(ctr[0])
    for my, mx in zip(*whole):
        corners = np.array([[mx, my], [mx + 1, my], [mx, my + 1], [mx + 1, my + 1]]) * 0.1
        assert (np.abs(corners[:, 0] - 1.0) + np.abs(corners[:, 1] - 1.0) <= 0.6 + 1e-9).all()
    # Off the grid: only the cells on it.
    my, mx = cells_inside_convex(square - 1.0, g, 0.0)
    assert len(my) == 25 and mx.max() == 4


def test_inf_readings_clear_but_never_mark(footprint):
    lc = _local(footprint)
    layer = lc.layer("obstacle_layer")
    layer.add_observation(scan_to_observation(np.full(9, 1.5), -0.4, 0.1, 0.1, 30.0, (0.0, 0.0, 0.0)))
    lc.update_map(0.0, 0.0, 0.0)
    # All beams now report no return; with inf_is_valid they clear out to raytrace_range.
    obs = scan_to_observation(np.full(9, np.inf), -0.4, 0.1, 0.1, 30.0, (0.0, 0.0, 0.0),
                              inf_is_valid=True, obstacle_range=100.0, raytrace_range=3.0)
    assert not obs.mark.any()
    layer.add_observation(obs)
    lc.update_map(0.0, 0.0, 0.0)
    assert (lc.master.data != cv.LETHAL_OBSTACLE).all()
    # Without inf_is_valid, inf beams are dropped: no clearing, no marking.
    obs2 = scan_to_observation(np.full(9, np.inf), -0.4, 0.1, 0.1, 30.0, (0.0, 0.0, 0.0))
    assert len(obs2.points) == 0


def test_rolling_window_shifts_data(footprint):
    lc = _local(footprint)
    layer = lc.layer("obstacle_layer")
    lc.update_map(0.0, 0.0, 0.0)
    layer.add_observation(scan_to_observation(np.array([1.0]), 0.0, 0.1, 0.1, 30.0, (0.0, 0.0, 0.0)))
    lc.update_map(0.0, 0.0, 0.0)
    assert lc.master.cost_at(1.02, 0.0) == cv.LETHAL_OBSTACLE
    ox = lc.master.origin_x
    lc.update_map(0.5, 0.25, 0.0)
    assert lc.master.origin_x == pytest.approx(ox + 0.5)
    assert lc.master.cost_at(1.02, 0.0) == cv.LETHAL_OBSTACLE   # same world place, new cell
    cell = lc.master.world_to_map(1.02, 0.0)
    assert cell == (int((1.02 - lc.master.origin_x) / 0.05), int((0.0 - lc.master.origin_y) / 0.05))
    lc.update_map(10.0, 0.0, 0.0)  # moved out of the window: forgotten
    assert (lc.master.data == cv.FREE_SPACE).all()


def test_update_origin_keeps_overlap():
    c = Costmap2D(4, 3, 1.0)
    c.data[:] = np.arange(12).reshape(3, 4)
    c.update_origin(1.0, -1.0)
    npt.assert_array_equal(c.data, [[0, 0, 0, 0], [1, 2, 3, 0], [5, 6, 7, 0]])


def test_a_layer_name_it_does_not_read_is_noted_once(footprint):
    """costmap_2d's layers read their names and leave others unread (a vendor's costmap file
    often has some); ours log each once, naming the layer and the nearest name it reads."""
    logged = []
    lc = LayeredCostmap(Costmap2D(5, 5, 0.1), footprint, log=logged.append, name="local_costmap")
    lc.add_plugins([{"name": "i", "type": "costmap_2d::InflationLayer"},
                    {"name": "o", "type": "costmap_2d::ObstacleLayer"}],
                   {"i": {"inflation_radus": 1.0}, "o": {"observation_sources": "s", "s": {"topc": "scan"}}})
    assert lc.layer("i").inflation_radius == 0.55      # the default: the misspelt name is not read
    assert logged == [
        "local_costmap: inflation layer 'i': 'inflation_radus' is not a parameter this node reads; ignored "
        "(did you mean 'inflation_radius'?)",
        "local_costmap: obstacle layer 'o' source 's': 'topc' is not a parameter this node reads; ignored "
        "(did you mean 'topic'?)"]


def test_bad_plugins_and_params(footprint):
    with pytest.raises(CostmapError, match="unknown type"):
        LayeredCostmap.from_plugins([{"name": "x", "type": "costmap_2d::VoxelLayerX"}], {},
                                    Costmap2D(5, 5, 0.1), footprint)
    with pytest.raises(CostmapError):
        ObstacleLayer("o", {"observation_sources": "s", "s": {"data_type": "Sonar"}})


def test_costmap_publisher_sends_the_whole_grid_then_the_redrawn_windows():
    """costmap_2d's Costmap2DPublisher: the whole grid first and when the grid moves or
    changes size (or always, with always_send_full_costmap), else the union of the windows
    redrawn since the last cycle, clipped to the grid; nothing when none was."""
    from my_summit_path_planning.costmap import CostmapPublisher
    m = Costmap2D(20, 10, 0.1)
    pub = CostmapPublisher()
    assert pub.next(m) == ("full", None)
    assert pub.next(m) is None
    pub.add_window((2, 3, 5, 6))
    pub.add_window((4, 1, 7, 4))
    pub.add_window((9, 9, 9, 12))          # empty: ignored
    assert pub.next(m) == ("update", (2, 1, 7, 6))
    assert pub.next(m) is None
    pub.add_window((-3, 8, 25, 15))
    assert pub.next(m) == ("update", (0, 8, 20, 10))
    m.update_origin(0.5, 0.0)              # a rolling window moved
    pub.add_window((0, 0, 2, 2))
    assert pub.next(m) == ("full", None) and pub.next(m) is None
    always = CostmapPublisher(always_send_full_costmap=True)
    assert always.next(m) == always.next(m) == ("full", None)


def test_costmap_updates_rebuild_the_published_grid(footprint):
    """What a subscriber assembles from the whole grid and the updates (summit_nav_common's
    apply_update, as rviz and explore_lite do) equals the costmap at every cycle, with an
    obstacle that moves and a clear in between."""
    from my_summit_path_planning.costmap import CostmapPublisher
    from summit_nav_common.ros.costmap_client import apply_update
    params = {"obstacle_layer": {"observation_sources": "scan", "scan": {"clearing": True},
                                 "obstacle_range": 2.5, "raytrace_range": 3.0},
              "inflation_layer": {"inflation_radius": 0.5}}
    lc = LayeredCostmap.from_plugins([{"name": "obstacle_layer", "type": "costmap_2d::ObstacleLayer"},
                                      {"name": "inflation_layer", "type": "costmap_2d::InflationLayer"}],
                                     params, Costmap2D(120, 100, 0.05, -2.0, -2.5), footprint)
    pub, seen, updates = CostmapPublisher(), None, 0
    rng = np.random.default_rng(4)
    for cycle in range(12):
        ranges = np.full(9, rng.uniform(0.8, 2.2))
        lc.layer("obstacle_layer").add_observation(scan_to_observation(ranges, -0.4, 0.1, 0.1, 30.0, (0.0, 0.0, 0.0)))
        if cycle == 6:
            lc.reset()
            lc.force_full_update = True
        pub.add_window(lc.update_map(0.0, 0.0, 0.0))
        what = pub.next(lc.master)
        now = cv.costs_to_occupancy(lc.master.data)
        if what is not None and what[0] == "full":
            seen = now.copy()
        elif what is not None:
            x0, y0, x1, y1 = what[1]
            assert apply_update(seen, x0, y0, x1 - x0, y1 - y0, now[y0:y1, x0:x1].reshape(-1))
            updates += 1
        np.testing.assert_array_equal(seen, now)
    assert updates == 11
    assert not apply_update(seen, 110, 0, 20, 1, np.zeros(20))  # a window off the grid: nothing written
