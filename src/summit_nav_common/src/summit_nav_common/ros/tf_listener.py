"""A tf listener that does not read back its own node's broadcasts.

tf2_ros.TransformListener takes every /tf message, the node's own included. A SLAM node
broadcasts map -> odom every transform_publish_period of ROS time: at a bag's rate 4 that
is 80 messages a second that rospy writes to a socket, reads back in another thread and
deserializes, only for the node to look up odom -> base_link. Beside a simulated clock at
4x, a bare node doing just that took 3.7 % of a core, against 1.6 % for the clock alone
and 1.8 % broadcasting without listening; slam_karto's whole node used 10 % on ACES.
roscpp hands a node's own messages to its subscribers in-process, without a socket.

This listener does not connect its /tf subscription to its own node's publisher (rospy
has no in-process path, so the connection is refused where rospy makes it:
ROSHandler._connect_topic, for /tf only and only for this node's own URI), and the node's
broadcaster puts its own transforms into the buffer directly (`own`), so that the buffer
holds what tf2_ros's listener would have. Should a rospy without that method be met, the
connection is made and the own messages are dropped by their callerid before being
deserialized. Everything else is tf2_ros.TransformListener's: the same buffer, /tf_static,
the buffer cleared on a jump back in time.

TransformListener(buffer, on_update=None): on_update() runs after each message from
another node has been put into the buffer (a TfMessageFilter's tf_arrived). A node that
uses it must publish its own /tf only through something that calls own() (tf_broadcast).
"""
import threading

import rospy
import rospy.core
from rospy.impl import masterslave
from tf2_msgs.msg import TFMessage

TF_TOPIC = "/tf"
_own_skipped = set()     # topics whose subscription is not connected to this node's publisher


def _skip_own_publisher(topic):
    """From now on, rospy does not connect this node's subscription to `topic` to this
    node's own publisher of it. False when this rospy has no hook for it."""
    handler = getattr(masterslave, "ROSHandler", None)
    connect = getattr(handler, "_connect_topic", None)
    if connect is None:
        return False
    if not getattr(connect, "skips_own", False):
        def _connect_topic(self, topic, pub_uri):
            if topic in _own_skipped and pub_uri == rospy.core.get_node_uri():
                return 1, f"{topic}: own publisher not connected (summit_nav_common.ros.tf_listener)", 0
            return connect(self, topic, pub_uri)
        _connect_topic.skips_own = True
        handler._connect_topic = _connect_topic
    _own_skipped.add(topic)
    return True


class TransformListener:
    """/tf and /tf_static into buffer, but for this node's own messages (module docstring)."""

    def __init__(self, buffer, on_update=None):
        self.buffer = buffer
        self.on_update = on_update
        self.me = rospy.get_caller_id()
        self._last_update = rospy.Time.now()
        self._lock = threading.Lock()
        _skip_own_publisher(TF_TOPIC)
        self._subs = [rospy.Subscriber(TF_TOPIC, rospy.AnyMsg, self._on_tf, callback_args=False, buff_size=65536),
                      rospy.Subscriber("/tf_static", rospy.AnyMsg, self._on_tf, callback_args=True,
                                       buff_size=65536)]

    def own(self, transform):
        """A transform this node broadcasts (geometry_msgs/TransformStamped): into the buffer
        as if read back from /tf."""
        self.buffer.set_transform(transform, self.me)

    def unregister(self):
        for sub in self._subs:
            sub.unregister()

    def _on_tf(self, raw, static):
        who = raw._connection_header.get("callerid", "default_authority")
        if who == self.me and not static:
            return   # only where the connection to our own publisher was made after all
        msg = TFMessage().deserialize(raw._buff)
        self._check_for_reset()
        put = self.buffer.set_transform_static if static else self.buffer.set_transform
        for transform in msg.transforms:
            put(transform, who)
        if self.on_update is not None:
            self.on_update()

    def _check_for_reset(self):
        # as tf2_ros's listener: a bag started again clears the buffer
        with self._lock:
            now = rospy.Time.now()
            if now < self._last_update:
                rospy.logwarn(f"Detected jump back in time of {(self._last_update - now).to_sec():f}s. "
                              "Clearing TF buffer.")
                self.buffer.clear()
            self._last_update = now
