#!/usr/bin/python3
"""ekf_localization_node's ROS traffic without its filter: what rospy itself costs.

A baseline for bench_ekf.py's CPU figure (`bench_ekf.py --node THIS_FILE`): subscribes to
/odom (queue 50) and /imu/data (queue 100) as config/ekf.yaml configures the EKF, keeps
a tf2 listener, publishes odometry/filtered and the odom -> base_footprint transform at
50 Hz (an identity pose stamped with the last message's stamp) and a /diagnostics
status through the same NodeDiagnostics. Its pose is not an estimate: bench_ekf.py's
error figures of it mean nothing; its CPU per simulated second and peak RSS are the
floor under our node's (docs/ekf.md).
"""
import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")   # as the node does

import rospy  # noqa: E402
import tf2_ros  # noqa: E402
from geometry_msgs.msg import TransformStamped  # noqa: E402
from nav_msgs.msg import Odometry  # noqa: E402
from sensor_msgs.msg import Imu  # noqa: E402

from summit_nav_common.diagnostic_checks import OK, Check  # noqa: E402
from summit_nav_common.ros.diagnostics import NodeDiagnostics  # noqa: E402

PERIOD = 0.02   # [s] config/ekf.yaml's frequency 50 Hz


def main():
    rospy.init_node("ekf_se")
    last = {"stamp": None}

    def on_message(msg):
        last["stamp"] = msg.header.stamp

    buffer = tf2_ros.Buffer(rospy.Duration(10.0))
    tf2_ros.TransformListener(buffer)
    rospy.Subscriber("/odom", Odometry, on_message, queue_size=50)
    rospy.Subscriber("/imu/data", Imu, on_message, queue_size=100)
    pub = rospy.Publisher("odometry/filtered", Odometry, queue_size=10)
    broadcaster = tf2_ros.TransformBroadcaster()
    diagnostics = NodeDiagnostics("none")
    diagnostics.add("Filter", lambda now: Check(OK, "no filter: rospy's floor", ()))

    def on_timer(_event):
        if last["stamp"] is None:
            return
        odom = Odometry()
        odom.header.stamp, odom.header.frame_id, odom.child_frame_id = last["stamp"], "odom", "base_footprint"
        odom.pose.pose.orientation.w = 1.0
        pub.publish(odom)
        t = TransformStamped()
        t.header.stamp, t.header.frame_id, t.child_frame_id = last["stamp"], "odom", "base_footprint"
        t.transform.rotation.w = 1.0
        broadcaster.sendTransform(t)

    rospy.Timer(rospy.Duration(PERIOD), on_timer)
    rospy.spin()


if __name__ == "__main__":
    main()
