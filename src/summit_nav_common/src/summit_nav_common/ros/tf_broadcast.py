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

from . import map_msgs, rostime_wait
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
        """Send at every due time until shutdown. Times are integer nanoseconds of ROS time:
        a loop on rospy.Rate built and compared a few genpy Times per /clock message, which
        at a bag's 100 Hz clock cost more than the sending."""
        t = self.transform
        period, tolerance = _ns(self.period), _ns(self.tolerance.to_sec())
        due = last = None
        while not rospy.is_shutdown():
            now = _now_ns()
            restart = due is None or now < due - 2 * period      # the first, or the clock went back
            if restart or now >= due:
                # the simulated clock ticks in steps: a repeated stamp would be rejected by tf2
                if now != last:
                    last = now
                    x, y, yaw = self.pose()
                    t.header.stamp = rospy.Time(*divmod(now + tolerance, 10 ** 9))
                    t.transform.translation.x, t.transform.translation.y = float(x), float(y)
                    t.transform.rotation.z, t.transform.rotation.w = map_msgs.yaw_to_quaternion_zw(float(yaw))
                    if not publish_or_end(self.broadcaster.sendTransform, t):
                        return   # shutdown closed the topic after the loop's check
                    self.sent += 1
                # as ros::Rate: on the period's grid, started again when a period or more behind
                due = now + period if restart or now - due >= period else due + period
            _wait_until(due, now)


def _ns(seconds):
    return int(round(seconds * 1e9))


_now_ns = rostime_wait.now_ns


def _wait_until(due, now):
    """Until ROS time `due` [ns], or earlier (rostime_wait.wait_until)."""
    rostime_wait.wait_until(due)
