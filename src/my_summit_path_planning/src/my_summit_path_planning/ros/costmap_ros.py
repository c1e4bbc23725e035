"""A LayeredCostmap kept up to date from ROS: costmap_2d's Costmap2DROS.

Reference: costmap_2d's ``costmap_2d_ros.cpp`` (the update loop at update_frequency, the
robot pose from tf within transform_tolerance), ``costmap_2d_publisher.cpp`` (the whole
grid to a new subscriber and when the grid moved, the redrawn window on
~costmap_updates in between, only while ~costmap has a subscriber) and
``static_layer.cpp`` / ``obstacle_layer.cpp`` (the map topic; each reading placed by
the sensor's pose at its stamp). The costmap itself is the pure my_summit_path_planning
costmap and layers; this module converts messages and transforms for it. Its
collaborators are handed in (the tf buffer, the SensorHub), so tests drive it with a
tf2_ros.Buffer filled by hand and messages built in memory, without a ROS master.
"""
import threading

import numpy as np
import rospy
import tf2_ros
from geometry_msgs.msg import Point32, PolygonStamped
from map_msgs.msg import OccupancyGridUpdate
from nav_msgs.msg import OccupancyGrid
from rospy.numpy_msg import numpy_msg
from summit_nav_common.diagnostic_checks import RateMeter
from summit_nav_common.geometry import quaternion_to_yaw, transform_points_3d
from summit_nav_common.ros import tf_wait
from summit_nav_common.ros.clouds import CloudError, pointcloud2_xyz, pointcloud_xyz
from summit_nav_common.ros.shutdown import publish_or_end

from .. import cost_values, layers, params as mb_params
from ..costmap import CostmapPublisher

SENSOR_TF_TIMEOUT = 0.1      # [s of wall time] wait for a sensor's pose at a reading's stamp
WARN_PERIOD = 5.0            # [s] throttle of repeated warnings


def tf_to_pose(ts):
    """(x, y, yaw) of a geometry_msgs/TransformStamped."""
    tr = ts.transform
    return tr.translation.x, tr.translation.y, quaternion_to_yaw(tr.rotation)


class _WholeGridToNewSubscriber(rospy.SubscribeListener):
    """Sends a costmap's whole grid to each new subscriber of ~costmap, as costmap_2d's
    onNewSubscription does (the topic is not latched: between whole grids only the
    redrawn windows go out, on ~costmap_updates)."""

    def __init__(self, costmap):
        super().__init__()
        self.costmap = costmap

    def peer_subscribe(self, topic_name, topic_publish, peer_publish):
        cm = self.costmap
        if not cm.has_map or cm.layered.version == 0:
            return   # not drawn yet: the first publish cycle after the first update sends it
        with cm.lock:
            msg = cm.grid_msg(rospy.Time.now())
        peer_publish(msg)


class CostmapROS:
    """A LayeredCostmap kept up to date from ROS (costmap_2d's Costmap2DROS).

    name: 'global_costmap' or 'local_costmap'; cfg: params.CostmapConfig; tf_buffer:
    a tf2_ros.Buffer; sensors: a SensorHub shared by both costmaps. Updates run in their own
    thread at update_frequency; every access to ``layered`` holds ``lock``.
    """

    def __init__(self, name, cfg, tf_buffer, sensors):
        self.name = name
        self.cfg = cfg
        self.tf = tf_buffer
        self.global_frame = cfg.global_frame.lstrip("/")
        self.base_frame = cfg.robot_base_frame.lstrip("/")
        self.layered = mb_params.build_costmap(cfg, name, log=lambda m: rospy.logwarn(f"move_base: {m}"))
        self.lock = threading.RLock()
        self.static_layers = [l for l in self.layered.layers if isinstance(l, layers.StaticLayer)]
        self.obstacle_layers = [l for l in self.layered.layers if isinstance(l, layers.ObstacleLayer)]
        self.has_map = not self.static_layers  # a costmap without static layer needs no map
        self.sensors = sensors
        for layer in self.static_layers:
            rospy.Subscriber(layer.map_topic, numpy_msg(OccupancyGrid),
                             lambda msg, l=layer: self._on_map(l, msg), queue_size=1)
        for layer in self.obstacle_layers:
            for src in layer.sources.values():
                try:
                    sensors.watch(src["topic"], src["data_type"])
                except ValueError as e:
                    raise mb_params.ParamError(f"{name}: obstacle layer '{layer.name}' source "
                                               f"'{src['name']}': {e}") from None
        # costmap_2d's publisher: the whole grid to each new subscriber and when it moved or
        # changed size, the redrawn window on ~costmap_updates in between
        self.publication = CostmapPublisher(cfg.always_send_full_costmap)
        self.costmap_pub = rospy.Publisher(f"~{name}/costmap", numpy_msg(OccupancyGrid), queue_size=1,
                                           subscriber_listener=_WholeGridToNewSubscriber(self))
        self.updates_pub = rospy.Publisher(f"~{name}/costmap_updates", numpy_msg(OccupancyGridUpdate),
                                           queue_size=1)
        self.footprint_pub = rospy.Publisher(f"~{name}/footprint", PolygonStamped, queue_size=1)
        self.robot_pose = None
        self.update_rate = RateMeter()   # successful updates [ROS time], for /diagnostics

    # -- inputs -------------------------------------------------------------------------
    def _on_map(self, layer, msg):
        if layer.first_map_only and layer.grid is not None:
            return
        o = msg.info.origin
        with self.lock:
            try:
                data = np.asarray(msg.data, dtype=np.int8).reshape(msg.info.height, msg.info.width)
                layer.set_map(data, msg.info.resolution, (o.position.x, o.position.y, quaternion_to_yaw(o.orientation)))
            except Exception as e:  # noqa: BLE001 - a bad map must not kill the node
                rospy.logerr(f"move_base: {self.name}: map on {layer.map_topic} rejected: {e}")
                return
            self.has_map = all(l.grid is not None for l in self.static_layers)
        rospy.loginfo(f"move_base: {self.name}: map {msg.info.width} x {msg.info.height} cells at "
                      f"{msg.info.resolution:.3f} m received on {layer.map_topic}")

    def get_robot_pose(self):
        """(x, y, yaw) of robot_base_frame in global_frame, or None (with a warning)."""
        try:
            t = self.tf.lookup_transform(self.global_frame, self.base_frame, rospy.Time(0))
        except (tf2_ros.LookupException, tf2_ros.ConnectivityException, tf2_ros.ExtrapolationException) as e:
            rospy.logwarn_throttle(WARN_PERIOD, f"move_base: {self.name}: no robot pose "
                                                f"{self.global_frame} -> {self.base_frame}: {e}")
            return None
        # A chain of static transforms has stamp 0 and never ages (costmap_2d skips a zero stamp).
        age = 0.0 if t.header.stamp.is_zero() else (rospy.Time.now() - t.header.stamp).to_sec()
        if age > self.cfg.transform_tolerance:
            rospy.logwarn_throttle(WARN_PERIOD, f"move_base: {self.name}: robot pose is {age:.2f} s old "
                                                f"(transform_tolerance {self.cfg.transform_tolerance} s)")
            return None
        return tf_to_pose(t)

    def _add_observations(self):
        for layer in self.obstacle_layers:
            for src in layer.sources.values():
                msg = self.sensors.take(src["topic"], id(layer))
                if msg is None:
                    continue
                if src["data_type"] == "LaserScan":
                    obs = self._scan_observation(src, msg)
                else:
                    obs = self._cloud_observation(src, msg)
                if obs is not None:
                    layer.add_observation(obs)

    def _sensor_pose(self, frame, stamp, what):
        """The TransformStamped global_frame <- frame at stamp, or None (with a warning)."""
        try:
            # in wall time (tf_wait), never on the simulator's /clock
            return tf_wait.lookup_at(self.tf, self.global_frame, frame, stamp, SENSOR_TF_TIMEOUT)
        except tf_wait.TF_ERRORS as e:
            rospy.logwarn_throttle(WARN_PERIOD, f"move_base: {self.name}: {what} dropped, no "
                                                f"transform {self.global_frame} -> {frame}: {e}")
            return None

    def _scan_observation(self, src, msg):
        frame = (src["sensor_frame"] or msg.header.frame_id).lstrip("/")
        t = self._sensor_pose(frame, msg.header.stamp, "scan")
        if t is None:
            return None
        return layers.source_observation(src, msg.ranges, msg.angle_min, msg.angle_increment, msg.range_min,
                                         msg.range_max, tf_to_pose(t), sensor_z=t.transform.translation.z)

    def _cloud_observation(self, src, msg):
        """A PointCloud(2)'s points in the global frame, from the sensor's origin (its
        sensor_frame, else the cloud's frame), as costmap_2d's observation buffer takes them."""
        cloud_frame = msg.header.frame_id.lstrip("/")
        t = self._sensor_pose(cloud_frame, msg.header.stamp, "cloud")
        if t is None:
            return None
        try:
            pts = pointcloud2_xyz(msg) if src["data_type"] == "PointCloud2" else pointcloud_xyz(msg)
        except CloudError as e:
            rospy.logwarn_throttle(WARN_PERIOD, f"move_base: {self.name}: cloud on {src['topic']} dropped: {e}")
            return None
        q, tr = t.transform.rotation, t.transform.translation
        origin = (tr.x, tr.y, tr.z)
        pts = transform_points_3d(pts, origin, (q.x, q.y, q.z, q.w))
        sensor_frame = src["sensor_frame"].lstrip("/")
        if sensor_frame and sensor_frame != cloud_frame:
            ts = self._sensor_pose(sensor_frame, msg.header.stamp, "cloud")
            if ts is None:
                return None
            origin = (ts.transform.translation.x, ts.transform.translation.y, ts.transform.translation.z)
        return layers.source_cloud_observation(src, pts, origin)

    # -- the update loop ------------------------------------------------------------------
    def update(self):
        """One costmap update at the robot's current pose; False when not possible yet."""
        if not self.has_map:
            return False
        pose = self.get_robot_pose()
        if pose is None:
            return False
        with self.lock:
            self._add_observations()
            self.publication.add_window(self.layered.update_map(*pose))
            self.robot_pose = pose
        self.update_rate.tick(rospy.Time.now().to_sec())
        return True

    def spin(self, stop):
        """Update at update_frequency and publish at publish_frequency until stop is set."""
        period = 1.0 / self.cfg.update_frequency if self.cfg.update_frequency > 0 else 0.1
        pub_period = 1.0 / self.cfg.publish_frequency if self.cfg.publish_frequency > 0 else None
        next_pub = rospy.Time(0)
        rate = rospy.Rate(1.0 / period)
        while not rospy.is_shutdown() and not stop.is_set():
            if self.cfg.update_frequency > 0 or not self.layered.version:
                try:
                    self.update()
                except Exception as e:  # noqa: BLE001 - one bad reading must not stop the costmap for good
                    rospy.logerr_throttle(WARN_PERIOD, f"move_base: {self.name}: update failed: "
                                                       f"{type(e).__name__}: {e}")
            now = rospy.Time.now()
            if pub_period is not None and now >= next_pub and self.layered.version:
                next_pub = now + rospy.Duration(pub_period)
                if not publish_or_end(self.publish, now):
                    return   # shutdown closed the topics after the loop's check
            try:
                rate.sleep()
            except rospy.ROSInterruptException:
                return
            except rospy.ROSTimeMovedBackwardsException:
                pass

    def grid_msg(self, stamp):
        """The whole master grid as an OccupancyGrid (costmap_2d's prepareGrid); the caller
        holds the lock."""
        m = self.layered.master
        msg = numpy_msg(OccupancyGrid)()
        msg.header.frame_id, msg.header.stamp = self.global_frame, stamp
        msg.info.map_load_time = stamp
        msg.info.width, msg.info.height, msg.info.resolution = m.size_x, m.size_y, m.resolution
        msg.info.origin.position.x, msg.info.origin.position.y = m.origin_x, m.origin_y
        msg.info.origin.orientation.w = 1.0
        msg.data = np.ascontiguousarray(cost_values.costs_to_occupancy(m.data)).reshape(-1)
        return msg

    def publish(self, stamp):
        """Costmap (whole or its redrawn window, as costmap_2d's publishCostmap: only while
        ~costmap has a subscriber) and footprint (only while someone listens)."""
        if self.costmap_pub.get_num_connections() > 0:
            update = None
            with self.lock:
                what = self.publication.next(self.layered.master)
                if what is not None and what[0] == "full":
                    grid = self.grid_msg(stamp)
                elif what is not None:
                    x0, y0, x1, y1 = what[1]
                    update = numpy_msg(OccupancyGridUpdate)()
                    update.header.frame_id, update.header.stamp = self.global_frame, stamp
                    update.x, update.y, update.width, update.height = x0, y0, x1 - x0, y1 - y0
                    update.data = np.ascontiguousarray(
                        cost_values.costs_to_occupancy(self.layered.master.data[y0:y1, x0:x1])).reshape(-1)
            if update is not None:
                self.updates_pub.publish(update)
            elif what is not None:
                self.costmap_pub.publish(grid)
        if self.footprint_pub.get_num_connections() > 0 and self.robot_pose is not None:
            poly = self.layered.footprint.oriented(*self.robot_pose)
            msg = PolygonStamped()
            msg.header.frame_id, msg.header.stamp = self.global_frame, stamp
            msg.polygon.points = [Point32(float(x), float(y), 0.0) for x, y in poly]
            self.footprint_pub.publish(msg)

    def snapshot(self):
        """A copy of the master Costmap2D (planning runs on it without holding the lock)."""
        with self.lock:
            return self.layered.master.copy()

    def reset(self):
        """Forget everything sensed (clear_costmaps)."""
        with self.lock:
            self.layered.reset()
            self.layered.force_full_update = True
