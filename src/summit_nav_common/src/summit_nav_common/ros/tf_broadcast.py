"""Broadcasting a node's own transforms; map -> odom every transform_publish_period, as
slam_gmapping's and slam_karto's publishLoop.

The real nodes broadcast their latest correction in a thread of its own at a fixed rate of
ROS time (ros::Rate: simulated time when use_sim_time), stamped `tolerance` ahead so that
lookups up to that far in the future succeed. With a listener (tf_listener.TransformListener)
each transform a node sends goes straight into its own buffer instead of coming back over /tf.
"""
import threading

import rospy
from geometry_msgs.msg import TransformStamped
from tf2_msgs.msg import TFMessage

from . import map_msgs
from .shutdown import publish_or_end


class TransformBroadcaster:
    """tf2_ros.TransformBroadcaster's sendTransform, and each transform into `listener`'s
    buffer (tf_listener.TransformListener.own), which does not read /tf back from its node."""

    def __init__(self, listener=None):
        self.listener = listener
        self.pub = rospy.Publisher("/tf", TFMessage, queue_size=100)

    def sendTransform(self, transform):
        self.pub.publish(TFMessage([transform]))
        if self.listener is not None:
            self.listener.own(transform)


class PeriodicTransform:
    """parent -> child from pose() (x [m], y [m], yaw [rad]) every period [s of ROS time],
    stamped now + tolerance [s]; start() runs it in a daemon thread until shutdown."""

    def __init__(self, parent, child, period, tolerance, pose, listener=None):
        if not period > 0.0:
            raise ValueError(f"the period must be > 0 s, got {period!r}")
        self.period, self.pose = float(period), pose
        self.tolerance = rospy.Duration.from_sec(float(tolerance))
        self.transform = TransformStamped()
        self.transform.header.frame_id, self.transform.child_frame_id = parent, child
        self.broadcaster = TransformBroadcaster(listener)
        self.sent = 0

    def start(self):
        threading.Thread(target=self.run, daemon=True).start()

    def run(self):
        rate = rospy.Rate(1.0 / self.period)
        t = self.transform
        last_stamp = None
        while not rospy.is_shutdown():
            stamp = rospy.Time.now() + self.tolerance
            # the simulated clock ticks in steps: a repeated stamp would be rejected by tf2
            if stamp != last_stamp:
                last_stamp = stamp
                x, y, yaw = self.pose()
                t.header.stamp = stamp
                t.transform.translation.x, t.transform.translation.y = float(x), float(y)
                t.transform.rotation.z, t.transform.rotation.w = map_msgs.yaw_to_quaternion_zw(float(yaw))
                if not publish_or_end(self.broadcaster.sendTransform, t):
                    return   # shutdown closed the topic after the loop's check
                self.sent += 1
            try:
                rate.sleep()
            except rospy.ROSInterruptException:
                return
