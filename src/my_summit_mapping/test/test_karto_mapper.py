"""KartoMapper: parameters, bad input, serialization, and a loop closed in a synthetic
square corridor (drifted odometry corrected)."""
import dataclasses
import math
import os

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from my_summit_mapping import metrics
from my_summit_mapping.karto.mapper import KartoMapper, KartoParams, LaserGeometry
from summit_nav_common.testing.scenes import ray_cast

N_BEAMS = 181
LASER = LaserGeometry(angle_min=-math.pi / 2, angle_increment=math.pi / 180, n_beams=N_BEAMS,
                      range_min=0.05, range_max=30.0, mount=(0.1, 0.0, 0.0))
ANGLES = LASER.angles()


HALF = 15.0   # outer wall at +-HALF, the corridor's centre line at +-(HALF - 1) [m]


def corridor_world():
    """A square loop corridor 2 m wide around a 26 m x 26 m block. Its walls are bare but
    for pillars of different sizes along the first half of the south side: there a scan
    pins the pose; elsewhere, with the corridor's end farther than the range threshold,
    nothing fixes the position along the corridor, so the odometry's scale error stays
    in the open-loop estimate until the loop is closed on the pillars."""
    segs = []

    def box(x0, y0, x1, y1):
        segs.extend([[x0, y0, x1, y0], [x1, y0, x1, y1], [x1, y1, x0, y1], [x0, y1, x0, y0]])

    box(-HALF, -HALF, HALF, HALF)                  # outer wall
    box(-HALF + 2, -HALF + 2, HALF - 2, HALF - 2)  # inner block
    rng = np.random.default_rng(7)
    for t in np.arange(-HALF + 0.5, 0.0, 1.3):      # pillars on the south side
        w, d = rng.uniform(0.2, 0.6), rng.uniform(0.15, 0.5)
        box(t, -HALF, t + w, -HALF + d)
        box(t + 0.4, -HALF + 2 - d, t + 0.4 + w, -HALF + 2)
    return np.array(segs)


WORLD = corridor_world()


def loop_path(step=0.3):
    """Poses (K, 3) along the corridor's centre line, counter-clockwise from its
    south-west corner, a bit more than one lap so the pillars are seen again."""
    c = HALF - 1
    corners = [(-c, -c), (c, -c), (c, c), (-c, c), (-c, -c), (-c + 9.0, -c)]
    poses = []
    for (x0, y0), (x1, y1) in zip(corners[:-1], corners[1:]):
        th = math.atan2(y1 - y0, x1 - x0)
        n = int(round(math.hypot(x1 - x0, y1 - y0) / step))
        for k in range(n):
            poses.append((x0 + (x1 - x0) * k / n, y0 + (y1 - y0) * k / n, th))
        for a in np.linspace(0.0, math.pi / 2, 5)[1:-1]:   # turn in place at the corner
            poses.append((x1, y1, th + a))
    return np.array(poses)


def scan_at(pose):
    lx = pose[0] + LASER.mount[0] * math.cos(pose[2])
    ly = pose[1] + LASER.mount[0] * math.sin(pose[2])
    return ray_cast((lx, ly, pose[2]), ANGLES, WORLD, max_range=LASER.range_max)


def drifted(truth, slip=1.08, heading_drift_per_m=0.01, seed=3):
    """Odometry that turns by a steady bias [rad/m] and, on the north side (y > 10 m, as
    on a slippery floor), overestimates distance by the factor `slip`."""
    rng = np.random.default_rng(seed)
    odom = [truth[0].copy()]
    for a, b in zip(truth[:-1], truth[1:]):
        c, s = math.cos(a[2]), math.sin(a[2])
        d = b[:2] - a[:2]
        dx, dy, dth = c * d[0] + s * d[1], -s * d[0] + c * d[1], b[2] - a[2]
        dist = math.hypot(dx, dy)
        dth += heading_drift_per_m * dist + rng.normal(0, 0.002)
        if a[1] > 10.0:
            dx *= slip
        o = odom[-1]
        co, so = math.cos(o[2]), math.sin(o[2])
        odom.append(np.array([o[0] + co * dx - so * dy, o[1] + so * dx + co * dy, o[2] + dth]))
    return np.array(odom)


@pytest.fixture(scope="module")
def loop_data():
    truth = loop_path()
    return truth, drifted(truth), np.array([scan_at(p) for p in truth])


def run(truth, odom, scans, **params):
    mapper = KartoMapper(KartoParams.from_params(params)[0], LASER)
    nodes = []
    for k, (r, o) in enumerate(zip(scans, odom)):
        if mapper.add_scan(r, o, float(k)) is not None:
            nodes.append(k)
    return mapper, np.array(nodes)


# ------------------------------------------------------------------ parameters
def test_params_defaults_alias_and_unknown_keys():
    p, notes = KartoParams.from_params({"delta": 0.1, "foo": 1, "throttle_scans": 2})
    assert p.resolution == 0.1 and p.throttle_scans == 2
    assert p.minimum_travel_heading == pytest.approx(math.radians(10))
    assert any("foo" in n for n in notes)
    assert KartoParams().loop_match_maximum_variance_coarse == pytest.approx(0.4)


def test_variance_parameters_take_slam_karto_values_and_square_them():
    """slam_karto hands distance_variance_penalty, angle_variance_penalty and
    loop_match_maximum_variance_coarse to open_karto's setters, which square them: its
    documented defaults 0.3, 0.349 and 0.4 are open_karto's variances 0.09, 0.1218 and
    0.16. Ours took the YAML value as the variance, so a user's 0.3 penalized 3.3 times
    more loosely than the real node."""
    p = KartoParams()
    assert (p.distance_variance_penalty, p.angle_variance_penalty) == pytest.approx((0.3, math.radians(20.0)))
    settings = KartoMapper(p, LASER)._sequential.settings
    assert settings.distance_variance_penalty == pytest.approx(0.09)
    assert settings.angle_variance_penalty == pytest.approx(math.radians(20.0) ** 2)
    yaml_values, _ = KartoParams.from_params({"distance_variance_penalty": 0.5, "angle_variance_penalty": 0.2})
    settings = KartoMapper(yaml_values, LASER)._sequential.settings
    assert (settings.distance_variance_penalty, settings.angle_variance_penalty) == pytest.approx((0.25, 0.04))


@pytest.mark.parametrize("bad", [{"resolution": -1.0}, {"throttle_scans": 0}, {"do_loop_closing": "yes"},
                                 {"scan_buffer_size": 2.5}, {"loop_match_minimum_response_fine": 1.5},
                                 {"minimum_travel_distance": float("nan")}])
def test_bad_params_name_the_parameter(bad):
    with pytest.raises(ValueError, match=list(bad)[0]):
        KartoParams.from_params(bad)


# ------------------------------------------------------------------ bad input
def test_wrong_beam_count_raises_and_changes_nothing(loop_data):
    truth, odom, scans = loop_data
    mapper, _ = run(truth[:5], odom[:5], scans[:5])
    before = mapper.node_poses().copy()
    with pytest.raises(ValueError, match="beams"):
        mapper.add_scan(np.ones(N_BEAMS - 1), odom[5], 5.0)
    assert_array_equal(mapper.node_poses(), before)
    assert mapper.add_scan(scans[5], odom[5], 5.0) is not None


def test_nan_and_inf_readings_are_no_returns(loop_data):
    truth, odom, scans = loop_data
    bad = scans[:8].copy()
    bad[:, ::3] = np.nan
    bad[:, 1::7] = np.inf
    mapper, nodes = run(truth[:8], odom[:8], bad)
    assert len(nodes) == 8
    assert np.all(np.isfinite(mapper.node_poses()))
    p = mapper.node_poses()
    err = metrics.ate_rmse(p, truth[nodes])
    assert err < 0.05


def test_throttle_and_travel_gate(loop_data):
    truth, odom, scans = loop_data
    mapper = KartoMapper(KartoParams(throttle_scans=2), LASER)
    assert mapper.add_scan(scans[0], odom[0], 0.0) is None        # 1st of every 2 skipped
    assert mapper.add_scan(scans[1], odom[1], 1.0) is not None
    mapper.add_scan(scans[1], odom[1], 2.0)
    assert mapper.add_scan(scans[1], odom[1], 3.0) is None        # did not move
    assert mapper.stats["nodes"] == 1


# ------------------------------------------------------------------ the loop
@pytest.fixture(scope="module")
def closed_and_open(loop_data):
    truth, odom, scans = loop_data
    closed = run(truth, odom, scans)
    opened = run(truth, odom, scans, do_loop_closing=False)
    return closed, opened


def test_square_corridor_loop_is_closed_and_drift_corrected(loop_data, closed_and_open):
    truth, odom, scans = loop_data
    (mapper, nodes), (open_mapper, open_nodes) = closed_and_open
    assert mapper.stats["loop_closures"] >= 1
    assert any(kind == "loop" for _, _, kind in mapper.edges())
    closed_err = metrics.ate_rmse(mapper.node_poses(), truth[nodes])
    open_err = metrics.ate_rmse(open_mapper.node_poses(), truth[open_nodes])
    odom_err = metrics.ate_rmse(odom, truth)
    assert open_err < odom_err
    assert closed_err < 0.8 * open_err, (closed_err, open_err)
    # the latest pose against the truth (map frame = world frame: the odometry starts at
    # the true pose): the closure took back most of the slip
    def end_error(m, n):
        return float(np.hypot(*(m.node_poses()[-1, :2] - truth[n[-1], :2])))
    assert end_error(mapper, nodes) < 0.5 * end_error(open_mapper, open_nodes), \
        (end_error(mapper, nodes), end_error(open_mapper, open_nodes))


def test_loop_closure_beyond_the_bound_is_rejected_and_logged(loop_data):
    truth, odom, scans = loop_data
    mapper, _ = run(truth, odom, scans, loop_closure_max_correction=0.3)
    assert mapper.stats["rejected_loop_closures"] >= 1
    assert mapper.stats["loop_closures"] == 0
    assert not any(kind == "loop" for _, _, kind in mapper.edges())
    notes = mapper.take_log()
    assert notes and all("loop_closure_max_correction" in n for n in notes)
    assert mapper.take_log() == []


def test_map_has_the_corridor_walls(closed_and_open):
    mapper, nodes = closed_and_open[0]
    grid, origin = mapper.occupancy_grid(0.1)
    assert grid.dtype == np.int8 and set(np.unique(grid)) <= {-1, 0, 100}
    rot, t = metrics.rigid_alignment_2d(mapper.node_poses(), loop_path()[nodes])

    def cell(x, y):   # world point -> map cell
        mx, my = rot.T @ (np.array([x, y]) - t)
        return grid[int((my - origin[1]) / 0.1), int((mx - origin[0]) / 0.1)]
    # where the loop was closed: the corridor's centre line is free, the inner block's
    # wall next to it (between two pillars) occupied
    assert cell(-9.3, -HALF + 1) == 0
    assert 100 in [cell(-9.3, -HALF + 2 + d) for d in np.arange(-0.3, 0.31, 0.05)]


def test_map_drawn_as_the_node_draws_it_equals_a_fresh_cast(loop_data):
    """The node asks for a map every few seconds; the mapper casts again only the nodes
    added since, while the loop closures in between move every pose and force a whole
    cast. Each map equals render() of all the graph's scans from its current poses."""
    from my_summit_mapping.karto.render import render
    truth, odom, scans = loop_data
    mapper = KartoMapper(KartoParams(), LASER)
    maps = closures = 0
    for k, (r, o) in enumerate(zip(scans, odom)):
        res = mapper.add_scan(r, o, float(k))
        closures += bool(res is not None and res.loop_closed)
        if k % 7 == 0 or (res is not None and res.loop_closed):
            ranges = np.array([n.ranges for n in mapper.graph.nodes], float)
            ranges[~(ranges >= LASER.range_min)] = np.nan
            fresh = render(mapper.graph.poses(), ranges, ANGLES, LASER.mount, mapper.params.range_threshold,
                           LASER.range_max, 0.1)
            grid, origin = mapper.occupancy_grid(0.1)
            assert_array_equal(grid, fresh[0])
            assert origin == fresh[1]
            maps += 1
    assert closures >= 1 and maps > 10


def test_the_map_is_cast_a_chunk_of_scans_at_a_time(loop_data, monkeypatch):
    """After a loop closure the whole graph is cast again; the renderer asks the mapper
    for CHUNK nodes' scans at a time, not all of them at once (35 MB in float64 for
    willow-full's 4000 nodes), and the map is the same as one cast of all of them."""
    from my_summit_mapping.karto import render as render_module
    truth, odom, scans = loop_data
    mapper = KartoMapper(KartoParams(), LASER)
    for r, o, k in zip(scans, odom, range(len(scans))):
        mapper.add_scan(r, o, float(k))
    n = len(mapper.graph.nodes)
    assert n > 12
    whole, origin = render_module.render(mapper.graph.poses(), np.array(
        [np.where(nd.ranges >= LASER.range_min, nd.ranges, np.nan) for nd in mapper.graph.nodes], float),
        ANGLES, LASER.mount, mapper.params.range_threshold, LASER.range_max, 0.1)
    monkeypatch.setattr(render_module, "CHUNK", 5)
    asked = []
    real = mapper._renderer.render

    def spy(poses, ranges, *args):
        return real(poses, lambda k0, k1: (asked.append((k0, k1)), ranges(k0, k1))[1], *args)
    monkeypatch.setattr(mapper._renderer, "render", spy)
    grid, origin2 = mapper.occupancy_grid(0.1)
    assert_array_equal(grid, whole)
    assert origin2 == origin
    assert asked == [(k, min(k + 5, n)) for k in range(0, n, 5)]


# ------------------------------------------------------------------ serialization
def test_save_load_round_trip_and_continue(tmp_path, loop_data):
    truth, odom, scans = loop_data
    mapper, nodes = run(truth[:40], odom[:40], scans[:40])
    path = str(tmp_path / "graph.npz")
    mapper.save(path)
    back = KartoMapper.load(path)
    assert_allclose(back.node_poses(), mapper.node_poses())
    assert back.edges() == mapper.edges()
    assert_array_equal(back.occupancy_grid()[0], mapper.occupancy_grid()[0])
    assert back.params == mapper.params and back.laser == mapper.laser
    # a new session: odometry restarted at zero, the robot where the old run ended
    k = 40
    new_odom0 = np.zeros(3)
    back.start_at(truth[k] + np.array([0.05, -0.04, 0.02]), new_odom0)
    res = back.add_scan(scans[k], new_odom0, 100.0)
    assert res is not None and res.node_id == len(nodes)
    assert_allclose(res.pose[:2], truth[k, :2], atol=0.03)
    assert abs(res.pose[2] - truth[k, 2]) < 0.01
    assert any(j == res.node_id for _, j, _ in back.edges())


def test_version_1_file_reads_its_variances_as_slam_karto_values(tmp_path, loop_data, monkeypatch):
    """Format 1 stored the three "variance" parameters as variances; they read back as the
    square roots that KartoParams now holds."""
    from my_summit_mapping.karto import serialize
    truth, odom, scans = loop_data
    mapper, _ = run(truth[:10], odom[:10], scans[:10])
    mapper.params = dataclasses.replace(mapper.params, distance_variance_penalty=0.09,
                                        angle_variance_penalty=0.04, loop_match_maximum_variance_coarse=0.16)
    monkeypatch.setattr(serialize, "FORMAT_VERSION", 1)
    path = str(tmp_path / "v1.npz")
    mapper.save(path)
    monkeypatch.undo()
    back = KartoMapper.load(path)
    assert (back.params.distance_variance_penalty, back.params.angle_variance_penalty,
            back.params.loop_match_maximum_variance_coarse) == pytest.approx((0.3, 0.2, 0.4))
    monkeypatch.setattr(serialize, "FORMAT_VERSION", 7)
    mapper.save(str(tmp_path / "v7.npz"))
    monkeypatch.undo()
    with pytest.raises(ValueError, match="v7.npz: format version 7"):
        KartoMapper.load(str(tmp_path / "v7.npz"))


def test_corrupt_and_foreign_files_raise_value_error(tmp_path, loop_data):
    truth, odom, scans = loop_data
    mapper, _ = run(truth[:10], odom[:10], scans[:10])
    path = str(tmp_path / "graph.npz")
    mapper.save(path)
    blob = open(path, "rb").read()
    (tmp_path / "truncated.npz").write_bytes(blob[: len(blob) // 2])
    flipped = bytearray(blob)
    flipped[len(blob) // 2] ^= 0xFF
    (tmp_path / "flipped.npz").write_bytes(bytes(flipped))
    np.savez(str(tmp_path / "foreign.npz"), a=np.arange(3))
    (tmp_path / "text.npz").write_text("hello")
    for name in ("truncated.npz", "flipped.npz", "foreign.npz", "text.npz", "missing.npz"):
        with pytest.raises(ValueError, match=name):
            KartoMapper.load(str(tmp_path / name))
    assert not [f for f in os.listdir(tmp_path) if f.endswith(".tmp")]


def test_reference_in_map_follows_every_change_of_the_pose():
    """Node.reference_in_map is kept per pose (read ~140 times per node on Intel): a pose
    set anew (set_poses, the weighted mean) or changed in place must not read the old one."""
    from my_summit_mapping.karto.pose_graph import Node, PoseGraph, transform_points
    pts = np.array([[1.0, 0.0], [2.0, 0.5], [0.5, -1.0]])
    node = Node(id=0, stamp=0.0, odom_pose=np.zeros(3), pose=np.array([1.0, 2.0, 0.3]), ranges=np.ones(3, np.float32),
                points=pts, barycenter=pts.mean(axis=0))
    first = node.reference_in_map()
    assert_array_equal(first, transform_points(node.pose, pts).astype(np.float32))
    assert node.reference_in_map() is first and not first.flags.writeable   # shared, so read-only
    g = PoseGraph()
    g.add_node(node)
    g.set_poses(np.array([[-1.0, 0.5, 2.0]]))
    assert_array_equal(node.reference_in_map(), transform_points([-1.0, 0.5, 2.0], pts).astype(np.float32))
    node.pose[2] = -0.7
    assert_array_equal(node.reference_in_map(), transform_points([-1.0, 0.5, -0.7], pts).astype(np.float32))


def test_the_reference_cache_keeps_the_nodes_read_last():
    """ReferenceCache holds the map-frame reference of its `capacity` nodes read most
    recently; a node dropped from it computes its reference again, the same."""
    from my_summit_mapping.karto.pose_graph import Node, ReferenceCache, transform_points
    pts = np.array([[1.0, 0.0], [2.0, 0.5], [0.5, -1.0]])
    nodes = [Node(id=k, stamp=0.0, odom_pose=np.zeros(3), pose=np.array([k, 0.0, 0.1 * k]),
                  ranges=np.ones(3, np.float32), points=pts, barycenter=pts.mean(axis=0)) for k in range(5)]
    cache = ReferenceCache(3)
    for k in (0, 1, 2, 0, 3, 4):          # 1 and 2 read longest ago when 3 and 4 come
        ref = cache.get(nodes[k])
        assert_array_equal(ref, transform_points(nodes[k].pose, pts).astype(np.float32))
    assert len(cache) == 3
    assert [n._reference_cache is not None for n in nodes] == [True, False, False, True, True]
    again = cache.get(nodes[1])
    assert_array_equal(again, transform_points(nodes[1].pose, pts).astype(np.float32))
    assert nodes[0]._reference_cache is None          # now the one read longest ago


def test_a_node_keeps_its_scan_once(loop_data):
    """A node's matching points are a view of its reference (float32, those points first),
    its map-frame reference a float32 copy: on willow-full 2500 nodes of 1081 beams held
    the points and the reference as separate float64 arrays, with a float64 cache beside
    them, 56 kB a node. The points are the readings within range_threshold minus
    QUERY_RANGE_MARGIN, the reference all within range_threshold."""
    from my_summit_mapping.karto.mapper import QUERY_RANGE_MARGIN
    truth, odom, scans = loop_data
    mapper, nodes = run(truth[:6], odom[:6], scans[:6])
    lim = min(LASER.range_max, mapper.params.range_threshold)
    for node, k in zip(mapper.graph.nodes, nodes):
        assert node.reference.dtype == np.float32 and node.points.base is node.reference
        assert_array_equal(node.points, node.reference[:len(node.points)])
        r = scans[k]
        ok = np.isfinite(r) & (r <= lim)
        assert len(node.reference) == ok.sum()
        assert len(node.points) == (ok & (r <= lim - QUERY_RANGE_MARGIN)).sum()
        assert node.reference_in_map().dtype == np.float32
        per_node = node.ranges.nbytes + node.reference.nbytes + node.reference_in_map().nbytes
        assert per_node <= 4 * len(r) + 2 * 8 * ok.sum()
