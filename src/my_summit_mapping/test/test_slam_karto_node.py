"""slam_karto's ROS adapter without a ROS master: rospy's pieces replaced by fakes, scans of
a robot driving through a synthetic room fed through the node's own callbacks (scan
subscriber, tf message filter, scan worker) into the real core.

What is checked: the pose graph drawn as slam_karto draws it; the parameters split between
node and core; bad scans (another beam count, all NaN) skipped with a message while the
good ones go on; ~serialize_map -> ~deserialize_map gives back the same graph and map and
mapping continues on it; corrupt, foreign and missing files, a laser that does not fit
and slam_toolbox's localization mode refused with the reason, the current graph kept.
"""
import os
from pathlib import Path

import numpy as np
import pytest
import rospy
import tf2_ros
from geometry_msgs.msg import TransformStamped
from sensor_msgs.msg import LaserScan
from visualization_msgs.msg import Marker

from my_summit_mapping.srv import DeserializePoseGraphRequest, SerializePoseGraphRequest
from summit_nav_common.testing.nodes import load_node_module as load_node
from summit_nav_common.testing.scenes import ANGLES, ray_cast

NODE = Path(__file__).resolve().parents[1] / "nodes" / "slam_karto"
PARAMS = dict(transform_publish_period=0.0, base_frame="base_link", map_update_interval=0.0)
LASER_X = 0.25        # laser mount in base_link [m]
RANGE_MAX = 30.0      # [m]
SCAN_RATE = 10.0      # [Hz]
T0 = 1.0              # first stamp [s] (0 means "latest" to tf)
IDLE = 60.0           # [s wall] the worker takes the scans within this


def load_node_module():
    return load_node(NODE, "slam_karto_node")


def base_pose(t):
    """A drive along y = 2.8 from x = -4 at 0.5 m/s, then a turn to the south [m, m, rad]."""
    s = 0.5 * (t - T0)
    if s <= 6.0:
        return np.array([-4.0 + s, 2.8, 0.0])
    return np.array([2.0 + 0.3 * (s - 6.0), 2.8, -0.5 * (s - 6.0)])


def stamped(frame, child, t, pose):
    msg = TransformStamped()
    msg.header.frame_id, msg.child_frame_id = frame, child
    msg.header.stamp = rospy.Time.from_sec(t)
    msg.transform.translation.x, msg.transform.translation.y = float(pose[0]), float(pose[1])
    msg.transform.rotation.z, msg.transform.rotation.w = np.sin(pose[2] / 2), np.cos(pose[2] / 2)
    return msg


def scan_at(k, t, angles=ANGLES):
    x, y, th = base_pose(t)
    scan = LaserScan()
    scan.header.seq, scan.header.frame_id = k, "laser"
    scan.header.stamp = rospy.Time.from_sec(t)
    scan.angle_min, scan.angle_increment = float(angles[0]), float(angles[1] - angles[0])
    scan.angle_max = float(angles[-1])
    scan.range_min, scan.range_max = 0.05, RANGE_MAX
    scan.ranges = ray_cast((x + LASER_X * np.cos(th), y + LASER_X * np.sin(th), th), angles).astype(np.float32)
    return scan


def tf_buffer(duration):
    buffer = tf2_ros.Buffer(cache_time=rospy.Duration(120.0), debug=False)
    buffer.set_transform_static(stamped("base_link", "laser", 0.0, (LASER_X, 0.0, 0.0)), "test")
    for k in range(int(duration * 50) + 2):   # odometry at 50 Hz, exact
        t = T0 + k / 50.0
        buffer.set_transform(stamped("odom", "base_link", t, base_pose(t)), "test")
    return buffer


class _Publisher:
    """Keeps what is published; `connections` subscribers."""
    made = {}

    def __init__(self, topic, *_args, **_kwargs):
        self.topic, self.sent, self.connections = topic, [], 1
        _Publisher.made[topic] = self

    def publish(self, msg):
        self.sent.append(msg)

    def get_num_connections(self):
        return self.connections


class _ScanStats:
    def __init__(self, _label):
        self.skipped = 0

    def observe(self, _topic, _header):
        return 0

    def drop(self, *_args):
        self.skipped += 1


class _Diagnostics:
    def __init__(self, *_args):
        self.checks = {}

    def add(self, name, check):
        self.checks[name] = check


@pytest.fixture
def node_module(monkeypatch):
    module = load_node_module()
    subscribers, warnings = {}, []
    _Publisher.made = {}
    monkeypatch.setattr(rospy, "get_name", lambda: "/slam_karto")
    monkeypatch.setattr(rospy, "Publisher", _Publisher)
    monkeypatch.setattr(rospy, "Service", lambda *args, **kwargs: None)
    monkeypatch.setattr(rospy, "Subscriber", lambda topic, _cls, cb, **kw: subscribers.__setitem__(topic, cb))
    monkeypatch.setattr(rospy.Time, "now", staticmethod(lambda: rospy.Time(0)))
    for name in ("logwarn_throttle", "logwarn", "logerr"):
        monkeypatch.setattr(rospy, name, lambda *args, _n=name: warnings.append(args[-1]))
    monkeypatch.setattr(rospy, "loginfo", lambda *args: None)
    monkeypatch.setattr(tf2_ros, "TransformBroadcaster", lambda: None)
    monkeypatch.setattr(module, "ScanStats", _ScanStats)
    monkeypatch.setattr(module, "NodeDiagnostics", _Diagnostics)
    return module, subscribers, warnings


def make_node(module, subscribers, duration, params=PARAMS):
    buffer = tf_buffer(duration)
    node = module.SlamKartoNode(buffer, dict(params))
    return node, buffer


def drive(node, subscribers, t_from, t_to, seq0=0):
    """Scans from t_from to t_to [s] through the node's callbacks; waits until the core took them."""
    k = seq0
    for t in np.arange(t_from, t_to, 1.0 / SCAN_RATE):
        subscribers["scan"](scan_at(k, float(t)))
        node.tf_listener.on_update()                    # another node's tf is in the buffer
        k += 1
    assert node.worker.wait_idle(IDLE), "the core did not take the scans in time"
    return k


def test_pose_graph_is_drawn_as_slam_karto_draws_it(node_module):
    module, _subs, _warn = node_module
    poses = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.1], [1.0, 1.0, 1.6], [0.1, 0.1, 3.0]])
    edges = [(0, 1, "sequential"), (1, 2, "sequential"), (2, 3, "odometry"), (3, 0, "loop")]
    arr = module.graph_markers(poses, edges, "map", rospy.Time(5), previous_count=12)
    spheres = [m for m in arr.markers if m.type == Marker.SPHERE and m.action == Marker.ADD]
    lines = [m for m in arr.markers if m.type == Marker.LINE_STRIP and m.action == Marker.ADD]
    deletes = [m for m in arr.markers if m.action == Marker.DELETE]
    assert [m.id for m in spheres] == [0, 1, 2, 3]
    np.testing.assert_allclose([(m.pose.position.x, m.pose.position.y) for m in spheres], poses[:, :2])
    assert all(m.ns == "karto" and m.header.frame_id == "map" and m.scale.x == 0.1 for m in arr.markers[:8])
    assert all((m.color.r, m.color.g, m.color.b, m.color.a) == (1.0, 0.0, 0.0, 1.0) for m in spheres)
    assert [m.id for m in lines] == [4, 5, 6, 7]
    assert [(p.x, p.y) for p in lines[3].points] == [(0.1, 0.1), (0.0, 0.0)]
    assert (lines[0].color.b, lines[3].color.b) == (1.0, 0.0) and lines[3].color.g > 0.5   # the loop stands out
    assert [m.id for m in deletes] == [8, 9, 10, 11]


def test_parameters_split_between_the_node_and_the_core(node_module):
    module, _subs, _warn = node_module
    node, core = module.split_params({"base_frame": "base_footprint", "throttle_scans": 2, "delta": 0.1,
                                      "do_loop_closing": False, "diagnostic_period": 2.0})
    assert node["base_frame"] == "base_footprint" and node["throttle_scans"] == 2
    assert node["odom_frame"] == "odom" and node["map_update_interval"] == 5.0 and node["transform_publish_period"] == 0.05
    assert core == {"delta": 0.1, "do_loop_closing": False}
    with pytest.raises(ValueError, match="throttle_scans"):
        module.split_params({"throttle_scans": 0})
    with pytest.raises(ValueError, match="map_update_interval"):
        module.split_params({"map_update_interval": float("nan")})


def test_usable_readings_are_finite_and_within_the_laser_range(node_module):
    module, _subs, _warn = node_module
    assert module.usable_readings(np.array([1.0, np.nan, 0.01, np.inf, 2.0, -np.inf, 31.0], np.float32),
                                  0.05, 30.0) == 2


def test_node_maps_the_drive_and_skips_bad_scans(node_module):
    module, subs, warnings = node_module
    node, _ = make_node(module, subs, 20.0)
    k = drive(node, subs, T0, T0 + 8.0)
    bad = scan_at(k, T0 + 8.05, ANGLES[::2])            # another beam count
    subs["scan"](bad)
    assert any("differ from the graph's laser" in w for w in warnings), warnings
    nan = scan_at(k + 1, T0 + 8.1)
    nan.ranges = np.full(len(nan.ranges), np.nan, np.float32)
    subs["scan"](nan)
    node.tf_listener.on_update()
    assert any("none of its" in w for w in warnings), warnings
    nodes = len(node.mapper.node_poses())
    drive(node, subs, T0 + 8.2, T0 + 14.0, k + 2)
    poses = node.mapper.node_poses()
    assert len(poses) >= 10                              # ~7 m of travel, a node every 0.2 m or 10 deg
    truth = base_pose(T0 + 13.9)
    np.testing.assert_allclose(node.mapper.pose()[:2], truth[:2], atol=0.05)
    maps = _Publisher.made["map"].sent
    assert maps and maps[-1].header.frame_id == "map" and maps[-1].info.resolution == pytest.approx(0.05)
    assert _Publisher.made["visualization_marker_array"].sent, "no graph drawn while subscribed"
    diag = node.diagnostics.checks["Pose graph"](0.0)
    assert f"{len(poses)} nodes" in diag.message


def test_serialize_then_deserialize_continues_the_same_graph(node_module, tmp_path):
    module, subs, warnings = node_module
    node, _ = make_node(module, subs, 20.0)
    k = drive(node, subs, T0, T0 + 10.0)
    saved_poses = np.array(node.mapper.node_poses())
    saved_map = np.asarray(_Publisher.made["map"].sent[-1].data).copy()
    base = str(tmp_path / "session1")
    module.SlamKartoNode.on_serialize(node, SerializePoseGraphRequest(filename=base))
    assert os.path.isfile(base + ".posegraph") and not [p for p in os.listdir(tmp_path) if ".tmp" in p]

    _Publisher.made = {}
    node2, _ = make_node(module, subs, 20.0)             # a later session: a fresh node
    req = DeserializePoseGraphRequest(filename=base, match_type=DeserializePoseGraphRequest.START_AT_FIRST_NODE)
    node2.on_deserialize(req)
    np.testing.assert_allclose(node2.mapper.node_poses(), saved_poses, atol=1e-9)
    assert node2.start_pose == pytest.approx(tuple(saved_poses[0]))
    np.testing.assert_array_equal(np.asarray(_Publisher.made["map"].sent[-1].data), saved_map)
    # the robot is back where the first session started: the new scans join the old graph
    drive(node2, subs, T0, T0 + 4.0, k)
    poses = node2.mapper.node_poses()
    assert len(poses) > len(saved_poses)
    np.testing.assert_allclose(node2.mapper.pose()[:2], base_pose(T0 + 3.9)[:2], atol=0.05)
    assert not [w for w in warnings if "error" in w.lower()], warnings


def test_bad_files_and_requests_are_refused_and_the_graph_kept(node_module, tmp_path):
    module, subs, _warnings = node_module
    node, _ = make_node(module, subs, 20.0)
    drive(node, subs, T0, T0 + 6.0)
    kept = np.array(node.mapper.node_poses())
    garbage = tmp_path / "garbage.posegraph"
    garbage.write_bytes(b"\x00\x01not a pose graph" * 100)
    good = str(tmp_path / "good")
    node.on_serialize(SerializePoseGraphRequest(filename=good))
    truncated = tmp_path / "truncated.posegraph"
    truncated.write_bytes(open(good + ".posegraph", "rb").read()[:200])
    foreign = tmp_path / "foreign.npz"
    np.savez(foreign, something=np.arange(4))
    start = DeserializePoseGraphRequest.START_AT_FIRST_NODE
    for name, match in [(str(garbage), "cannot load"), (str(truncated), "cannot load"), (str(foreign), "cannot load"),
                        (str(tmp_path / "missing"), "cannot load")]:
        with pytest.raises(rospy.ServiceException, match=match) as e:
            node.on_deserialize(DeserializePoseGraphRequest(filename=name, match_type=start))
        assert "current pose graph is kept" in str(e.value)
    with pytest.raises(rospy.ServiceException, match="LOCALIZE_AT_POSE"):
        node.on_deserialize(DeserializePoseGraphRequest(filename=good, match_type=3))
    with pytest.raises(rospy.ServiceException, match="match_type"):
        node.on_deserialize(DeserializePoseGraphRequest(filename=good, match_type=0))
    with pytest.raises(rospy.ServiceException, match="no filename"):
        node.on_serialize(SerializePoseGraphRequest(filename=" "))
    with pytest.raises(rospy.ServiceException, match="cannot write"):
        node.on_serialize(SerializePoseGraphRequest(filename=str(tmp_path / "no" / "such" / "dir" / "g")))
    np.testing.assert_allclose(node.mapper.node_poses(), kept)

    # a graph made with another laser (half the beams) does not fit this node's scans
    other = module.KartoMapper(node.params, module.LaserGeometry(float(ANGLES[0]), float(2 * (ANGLES[1] - ANGLES[0])),
                                                                 len(ANGLES[::2]), 0.05, RANGE_MAX,
                                                                 mount=(LASER_X, 0.0, 0.0)))
    other.add_scan(ray_cast((0.0, 0.0, 0.0), ANGLES[::2]), (0.0, 0.0, 0.0), 1.0)
    other_path = str(tmp_path / "other.posegraph")
    other.save(other_path)
    with pytest.raises(rospy.ServiceException, match="another laser"):
        node.on_deserialize(DeserializePoseGraphRequest(filename=other_path, match_type=start))
    np.testing.assert_allclose(node.mapper.node_poses(), kept)


def test_a_rejected_loop_closure_is_logged_once(node_module):
    """The core takes back a loop closure that would move a node too far and notes it in
    KartoMapper.log; the node logs each note once, as a warning."""
    module, subs, warnings = node_module
    node, _ = make_node(module, subs, 20.0)
    k = drive(node, subs, T0, T0 + 4.0)
    node.mapper.log.append("loop closure node 3 -> node 40 rejected: it would move node 12 by 4.1 m")
    k = drive(node, subs, T0 + 4.0, T0 + 6.0, k)
    drive(node, subs, T0 + 6.0, T0 + 8.0, k)
    assert sum("rejected: it would move node 12" in w for w in warnings) == 1, warnings


def test_the_node_feeds_the_core_what_an_offline_caller_would(node_module):
    """Laser geometry from tf and the scan, odometry from tf at each stamp, ranges as
    received: the node's graph is the one KartoMapper makes from the same drive offline."""
    module, subs, _warnings = node_module
    node, buffer = make_node(module, subs, 20.0)
    k = drive(node, subs, T0, T0 + 12.0)
    offline = module.KartoMapper(node.params, module.LaserGeometry(
        float(ANGLES[0]), float(ANGLES[1] - ANGLES[0]), len(ANGLES), 0.05, RANGE_MAX, mount=(LASER_X, 0.0, 0.0)))
    for j, t in enumerate(np.arange(T0, T0 + 12.0, 1.0 / SCAN_RATE)):
        scan = scan_at(j, float(t))
        odom = buffer.lookup_transform("odom", "base_link", scan.header.stamp).transform   # as the node gets it
        yaw = 2.0 * np.arctan2(odom.rotation.z, odom.rotation.w)
        offline.add_scan(np.asarray(scan.ranges, float), (odom.translation.x, odom.translation.y, yaw),
                         scan.header.stamp.to_sec())
    assert k == j + 1
    np.testing.assert_allclose(node.mapper.node_stamps(), offline.node_stamps())
    np.testing.assert_allclose(node.mapper.node_poses(), offline.node_poses(), atol=1e-6)
    np.testing.assert_allclose(node.map_to_odom, offline.map_to_odom(), atol=1e-6)
