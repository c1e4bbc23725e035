"""Unit tests of the wall-time transform wait (summit_nav_common.ros.tf_wait); no ROS master:
a plain tf2_ros.Buffer filled by hand."""
import threading
import time

import pytest
import rospy
import tf2_ros
from geometry_msgs.msg import TransformStamped

from summit_nav_common.ros import tf_wait


def odom_tf(t, x):
    m = TransformStamped()
    m.header.frame_id, m.child_frame_id = "odom", "base_footprint"
    m.header.stamp = rospy.Time.from_sec(t)
    m.transform.translation.x = x
    m.transform.rotation.w = 1.0
    return m


def buffer_up_to(t_last):
    buf = tf2_ros.Buffer(rospy.Duration(10.0), debug=False)
    for k in range(int(t_last * 10) + 1):
        buf.set_transform(odom_tf(k / 10.0, k / 10.0), "test")
    return buf


def test_at_hand_and_interpolated():
    buf = buffer_up_to(1.0)
    t0 = time.monotonic()
    t = tf_wait.lookup_at(buf, "odom", "base_footprint", rospy.Time.from_sec(0.55), 1.0)
    assert abs(t.transform.translation.x - 0.55) < 1e-9
    assert time.monotonic() - t0 < 0.1


def test_waits_in_wall_time_for_the_transform_on_its_way():
    # no /clock anywhere: a wait in ROS time would never see time pass
    buf = buffer_up_to(1.0)
    late = threading.Timer(0.15, lambda: buf.set_transform(odom_tf(1.1, 1.1), "test"))
    late.start()
    t0 = time.monotonic()
    t = tf_wait.lookup_at(buf, "odom", "base_footprint", rospy.Time.from_sec(1.05), 2.0)
    late.join()
    assert abs(t.transform.translation.x - 1.05) < 1e-9
    assert 0.1 < time.monotonic() - t0 < 1.0


def test_gives_up_after_the_wait_and_at_once_when_waiting_cannot_help():
    buf = buffer_up_to(1.0)
    t0 = time.monotonic()
    with pytest.raises(tf2_ros.ExtrapolationException):
        tf_wait.lookup_at(buf, "odom", "base_footprint", rospy.Time.from_sec(5.0), 0.2)
    assert 0.2 <= time.monotonic() - t0 < 0.6
    # older than the buffer holds: the transform will never come, no wait
    buf = tf2_ros.Buffer(rospy.Duration(10.0), debug=False)
    for k in range(5):
        buf.set_transform(odom_tf(20.0 + k / 10.0, 0.0), "test")
    t0 = time.monotonic()
    with pytest.raises(tf2_ros.ExtrapolationException):
        tf_wait.lookup_at(buf, "odom", "base_footprint", rospy.Time.from_sec(19.0), 1.0)
    assert time.monotonic() - t0 < 0.1
    # a frame nobody publishes: waited for (it may come), then the lookup error
    t0 = time.monotonic()
    with pytest.raises(tf2_ros.LookupException):
        tf_wait.lookup_at(buf, "odom", "laser", rospy.Time(0), 0.1)
    assert 0.1 <= time.monotonic() - t0 < 0.5
