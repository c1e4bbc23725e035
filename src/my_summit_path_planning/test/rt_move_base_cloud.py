#!/usr/bin/python3
"""rostest: move_base's obstacle layers take PointCloud2 and PointCloud sources as costmap_2d does.

move_base_cloud.test starts move_base alone with static tf (robot at (1, 2, yaw 0.5) in
odom; camera_link 0.2 m ahead, 0.5 m up, pitched 0.4 rad down) and one obstacle layer
with a PointCloud2 source (/test/cloud, height band 0.1-1.5 m) and a PointCloud one
(/test/old_cloud, published in camera_link, sensor_frame old_sensor 0.4 m above the
robot: its rays start there); the layer's max_obstacle_height is 1.2 m.
This node picks points in odom, writes them in the camera's frame (so the node's 3D
transform is what is checked), publishes them and reads ~local_costmap/costmap:

  marked:     a point 1.5 m ahead at z 0.3 (PointCloud2); one 1 m to the left at z 0.5
              (PointCloud)
  not marked: one at z 1.3 (in the band, above the layer's max), one at z 0.05 (below
              the band); a NaN point is dropped (the cloud still marks)
  cleared:    the 1.5 m hit, once a later cloud sees 2.0 m along the same ray
"""
import math
import time
import unittest

import rospy
import rostest
import sensor_msgs.point_cloud2 as pc2
import tf2_ros
from geometry_msgs.msg import Point32
from nav_msgs.msg import OccupancyGrid
from sensor_msgs.msg import PointCloud
from std_msgs.msg import Header
from summit_nav_common.geometry import transform_points_3d

ROBOT = (1.0, 2.0, 0.5)
WAIT = 30.0   # [s] wall


def ahead(dist, left=0.0):
    """(x, y) in odom of a point dist ahead of the robot and left to its left [m]."""
    x, y, a = ROBOT
    return x + dist * math.cos(a) - left * math.sin(a), y + dist * math.sin(a) + left * math.cos(a)


class CloudSources(unittest.TestCase):
    def setUp(self):
        rospy.init_node("move_base_cloud_test")
        self.grid = None
        rospy.Subscriber("/move_base/local_costmap/costmap", OccupancyGrid, self._on_grid, queue_size=1)
        self.cloud_pub = rospy.Publisher("/test/cloud", pc2.PointCloud2, queue_size=1)
        self.old_pub = rospy.Publisher("/test/old_cloud", PointCloud, queue_size=1)
        buf = tf2_ros.Buffer()
        self.listener = tf2_ros.TransformListener(buf)
        t = buf.lookup_transform("camera_link", "odom", rospy.Time(0), rospy.Duration(WAIT))
        q, tr = t.transform.rotation, t.transform.translation
        self.camera_from_odom = ((tr.x, tr.y, tr.z), (q.x, q.y, q.z, q.w))

    def _on_grid(self, msg):
        self.grid = msg

    def in_camera(self, pts_odom):
        return [tuple(p) for p in transform_points_3d(pts_odom, *self.camera_from_odom)]

    def cost(self, x, y):
        g = self.grid
        i = int(math.floor((x - g.info.origin.position.x) / g.info.resolution))
        j = int(math.floor((y - g.info.origin.position.y) / g.info.resolution))
        return g.data[j * g.info.width + i]

    def publish(self, cloud_odom, old_odom):
        h = Header(frame_id="camera_link", stamp=rospy.Time.now())
        self.cloud_pub.publish(pc2.create_cloud_xyz32(h, self.in_camera(cloud_odom)))
        if old_odom:
            self.old_pub.publish(PointCloud(header=h, points=[Point32(*p) for p in self.in_camera(old_odom)]))

    def wait_costs(self, cloud_odom, old_odom, expect):
        """Publish until every (x, y) of expect has its cost (100 or 0) in the costmap."""
        end = time.monotonic() + WAIT
        got = None
        while time.monotonic() < end and not rospy.is_shutdown():
            self.publish(cloud_odom, old_odom)
            rospy.sleep(0.3)
            if self.grid is not None:
                got = {k: self.cost(*k) for k in expect}
                if got == expect:
                    return
        self.fail(f"costmap cells {got}, expected {expect}")

    def test_clouds_mark_by_height_and_clear_along_rays(self):
        hit, left = ahead(1.5), ahead(0.0, 1.0)
        high, low = ahead(1.0, -1.0), ahead(2.0, 0.8)
        cloud = [(*hit, 0.3), (*high, 1.3), (*low, 0.05), (float("nan"), 0.0, 0.3)]
        self.wait_costs(cloud, [(*left, 0.5)], {hit: 100, left: 100, high: 0, low: 0})
        # The camera now sees 2.0 m along the ray through the first hit: that hit is cleared.
        cam_x, cam_y = ahead(0.2)
        beyond = (cam_x + (hit[0] - cam_x) * 1.8 / 1.3, cam_y + (hit[1] - cam_y) * 1.8 / 1.3)
        self.wait_costs([(*beyond, 0.3)], [], {hit: 0, beyond: 100})


if __name__ == "__main__":
    rostest.rosrun("my_summit_path_planning", "move_base_cloud", CloudSources)
