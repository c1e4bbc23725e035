"""move_base's ROS side of the costmaps (my_summit_path_planning.ros): CostmapROS and SensorHub
without a ROS master.

rospy's subscribers, publishers, clock and log are replaced by FakeRos (dicts and lists);
the tf buffer is a tf2_ros.Buffer filled by hand; the messages are built in memory. What
is checked: a map on the static layer's topic becomes the costmap's; a scan or cloud
marks where the sensor saw it, placed by the sensor's pose at the reading's stamp; the
robot pose is refused when missing or older than transform_tolerance; a bad map or a
reading without its transform is dropped with a message and the costmap keeps going;
publishing follows costmap_2d (whole grid, then the redrawn window, only with
subscribers; the whole grid to each new subscriber); each layer takes a reading once.
"""
import math

import numpy as np
import pytest
import rospy
import tf2_ros
from geometry_msgs.msg import TransformStamped
from nav_msgs.msg import OccupancyGrid
from sensor_msgs import point_cloud2
from sensor_msgs.msg import LaserScan
from std_msgs.msg import Header

from my_summit_path_planning import cost_values as cv
from my_summit_path_planning.params import ParamError, costmap_config
from my_summit_path_planning.ros.costmap_ros import CostmapROS, tf_to_pose
from my_summit_path_planning.ros.sensor_hub import SensorHub

NOW = 10.0          # [s] the fake ROS clock
ROBOT = (1.0, 2.0)  # [m] base_link in map
LASER = (0.2, 0.0, 0.3)   # [m] laser in base_link (x, y, z)


class FakePublisher:
    def __init__(self, name, listener=None):
        self.name, self.listener, self.sent, self.connections = name, listener, [], 0

    def publish(self, msg):
        self.sent.append(msg)

    def get_num_connections(self):
        return self.connections


class FakeRos:
    """rospy's Subscriber, Publisher, Time.now and log as dicts and lists."""

    def __init__(self, monkeypatch):
        self.now = NOW
        self.subscribers, self.publishers, self.logs = {}, {}, []
        monkeypatch.setattr(rospy, "Subscriber", self._subscriber)
        monkeypatch.setattr(rospy, "Publisher", self._publisher)
        monkeypatch.setattr(rospy.Time, "now", staticmethod(lambda: rospy.Time.from_sec(self.now)))
        for level in ("loginfo", "logwarn", "logerr"):
            monkeypatch.setattr(rospy, level, lambda text, level=level: self.logs.append((level, text)))
        for level in ("logwarn_throttle", "logerr_throttle"):
            monkeypatch.setattr(rospy, level, lambda _period, text, level=level: self.logs.append((level, text)))

    def _subscriber(self, topic, msg_type, callback, **_kw):
        self.subscribers[topic] = (msg_type, callback)

    def _publisher(self, name, _msg_type, **kw):
        self.publishers[name] = FakePublisher(name, kw.get("subscriber_listener"))
        return self.publishers[name]

    def said(self, level, words):
        return [t for lv, t in self.logs if lv == level and words in t]


class Stats:
    def __init__(self):
        self.seen = []

    def observe(self, topic, header):
        self.seen.append((topic, header.seq))


def transform(parent, child, x, y, z=0.0, yaw=0.0, stamp=NOW):
    t = TransformStamped()
    t.header.frame_id, t.child_frame_id = parent, child
    t.header.stamp = rospy.Time.from_sec(stamp)
    t.transform.translation.x, t.transform.translation.y, t.transform.translation.z = x, y, z
    t.transform.rotation.z, t.transform.rotation.w = math.sin(yaw / 2), math.cos(yaw / 2)
    return t


def tf_buffer(robot_stamp=NOW):
    """map -> base_link at ROBOT (a stamped transform), base_link -> laser (static)."""
    buf = tf2_ros.Buffer(rospy.Duration(10.0), debug=False)
    for s in (robot_stamp - 1.0, robot_stamp):
        buf.set_transform(transform("map", "base_link", *ROBOT, stamp=s), "test")
    buf.set_transform_static(transform("base_link", "laser", *LASER, stamp=0.0), "test")
    return buf


def config(**over):
    ns = {"global_frame": "map", "robot_base_frame": "base_link", "transform_tolerance": 0.3,
          "width": 5.0, "height": 5.0, "resolution": 0.05, "footprint": [[0.3, 0.2], [-0.3, 0.2], [-0.3, -0.2],
                                                                        [0.3, -0.2]],
          "plugins": [{"name": "static_layer", "type": "costmap_2d::StaticLayer"},
                      {"name": "obstacle_layer", "type": "costmap_2d::ObstacleLayer"}],
          "static_layer": {"map_topic": "map"},
          "obstacle_layer": {"observation_sources": "scan cloud",
                             "scan": {"data_type": "LaserScan", "topic": "scan", "marking": True, "clearing": True},
                             "cloud": {"data_type": "PointCloud2", "topic": "cloud", "marking": True}}}
    ns.update(over)
    return costmap_config(ns, "global_costmap")


def map_msg(width=100, height=100, resolution=0.05, data=None):
    msg = OccupancyGrid()
    msg.info.width, msg.info.height, msg.info.resolution = width, height, resolution
    msg.info.origin.orientation.w = 1.0
    msg.data = list(np.zeros(width * height, np.int8) if data is None else data)
    return msg


def scan_msg(range_ahead, frame="laser", stamp=NOW, seq=1):
    msg = LaserScan()
    msg.header.frame_id, msg.header.stamp, msg.header.seq = frame, rospy.Time.from_sec(stamp), seq
    msg.angle_min, msg.angle_max, msg.angle_increment = -0.01, 0.01, 0.01
    msg.range_min, msg.range_max = 0.1, 4.0
    msg.ranges = np.array([range_ahead] * 3, np.float32)
    return msg


def cost_at(cm, x, y):
    m = cm.layered.master
    return m.get_cost(*m.world_to_map(x, y))


@pytest.fixture
def ros(monkeypatch):
    return FakeRos(monkeypatch)


@pytest.fixture
def costmap(ros):
    """A global costmap with its map received (all free)."""
    cm = CostmapROS("global_costmap", config(), tf_buffer(), SensorHub(stats=Stats()))
    ros.subscribers["map"][1](map_msg())
    return cm


def deliver(ros, topic, msg):
    """What rospy does with a message on topic: the subscriber's callback."""
    ros.subscribers[topic][1](msg)


def test_subscribes_to_the_map_and_each_source_by_data_type(ros):
    hub = SensorHub(stats=Stats())
    cm = CostmapROS("global_costmap", config(), tf_buffer(), hub)
    assert sorted(ros.subscribers) == ["cloud", "map", "scan"]
    assert hub.types == {"scan": "LaserScan", "cloud": "PointCloud2"}
    assert {"~global_costmap/costmap", "~global_costmap/costmap_updates", "~global_costmap/footprint"} \
        <= set(ros.publishers)
    assert not cm.has_map and not cm.update()           # no map yet: nothing to update
    deliver(ros, "map", map_msg())
    assert cm.has_map and ros.said("loginfo", "map 100 x 100 cells at 0.050 m received on map")


def test_a_map_that_does_not_fit_its_size_is_rejected_and_the_costmap_goes_on(ros):
    """A map whose data is not width x height cells: once the reshape ran before the
    callback's try, so the error escaped to rospy (a traceback, no 'rejected' message)."""
    cm = CostmapROS("global_costmap", config(), tf_buffer(), SensorHub(stats=Stats()))
    deliver(ros, "map", map_msg(data=np.zeros(50, np.int8)))   # 50 cells for 100 x 100
    assert not cm.has_map and not ros.said("loginfo", "received")
    assert ros.said("logerr", "global_costmap: map on map rejected: cannot reshape")
    deliver(ros, "map", map_msg())
    assert cm.has_map


def test_robot_pose_from_tf_and_refused_when_stale_or_missing(ros, costmap):
    assert costmap.get_robot_pose() == pytest.approx((*ROBOT, 0.0))
    ros.now = NOW + 0.5                                   # the transform is 0.5 s old: over 0.3 s
    assert costmap.get_robot_pose() is None and ros.said("logwarn_throttle", "robot pose is 0.50 s old")
    lost = CostmapROS("global_costmap", config(robot_base_frame="base_footprint"), tf_buffer(),
                      SensorHub(stats=Stats()))
    assert lost.get_robot_pose() is None and ros.said("logwarn_throttle", "no robot pose map -> base_footprint")
    only_static = tf2_ros.Buffer(rospy.Duration(10.0), debug=False)
    only_static.set_transform_static(transform("map", "odom", 0.0, 0.0, stamp=0.0), "test")
    only_static.set_transform_static(transform("odom", "base_link", 3.0, 1.0, stamp=0.0), "test")
    static = CostmapROS("global_costmap", config(), only_static, SensorHub(stats=Stats()))
    ros.now = NOW + 100.0                                 # a chain of static transforms never ages
    assert static.get_robot_pose() == pytest.approx((3.0, 1.0, 0.0))


def test_a_scan_marks_where_the_laser_saw_it_in_the_global_frame(ros, costmap):
    deliver(ros, "scan", scan_msg(1.0))
    assert costmap.update()
    hit = (ROBOT[0] + LASER[0] + 1.0, ROBOT[1])           # 1 m ahead of the laser, 0.2 m ahead of the base
    assert cost_at(costmap, *hit) == cv.LETHAL_OBSTACLE
    assert cost_at(costmap, hit[0] - 0.5, hit[1]) == cv.FREE_SPACE
    assert costmap.robot_pose == pytest.approx((*ROBOT, 0.0)) and costmap.update_rate.read() is not None
    # each layer takes a reading once: the same scan is not added again after a reset
    costmap.reset()
    assert costmap.update() and cost_at(costmap, *hit) == cv.FREE_SPACE


def test_a_reading_without_its_sensor_transform_is_dropped_with_a_warning(ros, costmap):
    deliver(ros, "scan", scan_msg(1.0, frame="camera"))
    assert costmap.update()
    assert (costmap.layered.master.data == cv.FREE_SPACE).all()
    assert ros.said("logwarn_throttle", "scan dropped, no transform map -> camera")


def test_a_cloud_marks_its_points_from_the_sensor_origin(ros, costmap):
    header = Header(frame_id="laser", stamp=rospy.Time.from_sec(NOW), seq=1)
    deliver(ros, "cloud", point_cloud2.create_cloud_xyz32(header, [(1.5, 0.5, 0.0)]))
    assert costmap.update()
    assert cost_at(costmap, ROBOT[0] + LASER[0] + 1.5, ROBOT[1] + 0.5) == cv.LETHAL_OBSTACLE


def test_publishing_follows_costmap_2d_whole_grid_then_windows_only_with_subscribers(ros, costmap):
    grid, updates, footprint = (ros.publishers[f"~global_costmap/{t}"] for t in ("costmap", "costmap_updates",
                                                                                 "footprint"))
    assert costmap.update()
    stamp = rospy.Time.from_sec(NOW)
    costmap.publish(stamp)
    assert grid.sent == [] and footprint.sent == []       # nobody listens
    grid.connections = footprint.connections = 1
    costmap.publish(stamp)
    (whole,) = grid.sent
    assert (whole.info.width, whole.info.height, whole.header.frame_id) == (100, 100, "map")
    assert (np.asarray(whole.data) == 0).all()
    assert len(footprint.sent) == 1 and footprint.sent[0].polygon.points[0].x == pytest.approx(ROBOT[0] + 0.31)  # padded 0.01 m
    deliver(ros, "scan", scan_msg(1.0, seq=2))
    assert costmap.update()
    costmap.publish(stamp)
    (window,) = updates.sent
    assert len(grid.sent) == 1 and window.width < 100 and 100 in np.asarray(window.data)
    # a new subscriber is sent the whole grid at once, to it alone
    to_peer = []
    grid.listener.peer_subscribe("~global_costmap/costmap", None, to_peer.append)
    assert len(to_peer) == 1 and 100 in np.asarray(to_peer[0].data)


def test_sensor_hub_gives_each_layer_a_reading_once_and_counts_what_arrives(ros):
    stats = Stats()
    hub = SensorHub(stats=stats)
    hub.watch("scan", "LaserScan")
    hub.watch("scan", "LaserScan")                        # a second source on the same topic: one subscriber
    assert list(ros.subscribers) == ["scan"] and hub.take("scan", "a") is None
    with pytest.raises(ValueError, match="topic scan is read as LaserScan by another source, here as PointCloud2"):
        hub.watch("scan", "PointCloud2")
    first = scan_msg(1.0, seq=7)
    deliver(ros, "scan", first)
    assert hub.take("scan", "a") is first and hub.take("scan", "a") is None and hub.take("scan", "b") is first
    second = scan_msg(2.0, seq=8)
    deliver(ros, "scan", second)
    assert hub.take("scan", "a") is second and stats.seen == [("scan", 7), ("scan", 8)]


def test_a_source_read_as_two_types_is_a_parameter_error_naming_it(ros):
    hub = SensorHub(stats=Stats())
    hub.watch("scan", "PointCloud2")
    with pytest.raises(ParamError, match="global_costmap: obstacle layer 'obstacle_layer' source 'scan': topic scan"):
        CostmapROS("global_costmap", config(), tf_buffer(), hub)


def test_tf_to_pose_reads_position_and_yaw():
    assert tf_to_pose(transform("a", "b", 1.0, -2.0, yaw=0.7)) == pytest.approx((1.0, -2.0, 0.7))


def test_snapshot_is_a_copy_planning_can_use_without_the_lock(ros, costmap):
    assert costmap.update()
    snap = costmap.snapshot()
    snap.data[:] = cv.LETHAL_OBSTACLE
    assert (costmap.layered.master.data == cv.FREE_SPACE).all()
