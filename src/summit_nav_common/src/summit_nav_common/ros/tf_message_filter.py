"""Hold messages until tf can place them: the role of tf2_ros's MessageFilter, in Python.

amcl (amcl_node.cpp) receives scans through a tf MessageFilter: a scan whose stamp is
newer than the newest odom -> base transform waits in a queue and is handed over when that
transform arrives; nobody polls. rospy has no MessageFilter, and a simulator that sends
odometry at 50 Hz and scans at 40 Hz stamps four scans in five a few milliseconds
before the odometry that covers them, so a callback that polls the buffer for each scan
spends more CPU on the wait than on the scan.

TfMessageFilter(buffer, target, source, callback): ``add(msg)`` (from the message's
subscriber callback) hands ``callback(msg, transform)`` the message and the transform
target <- source at msg.header.stamp at once when the buffer has it, else queues the
message; ``tf_arrived()`` (from a /tf subscriber callback registered after the
tf2_ros.TransformListener, so the buffer already holds the new transforms) retries the
queue in order. A queued message is given up, through ``on_error(msg, exception)``, when
its transform has not come within ``timeout`` seconds of wall time (wall, not ROS time:
see tf_wait's docstring for why a wait in ROS time can stall the simulator), at once when
waiting cannot help (the stamp is older than the buffer, a frame is unknown or not
connected), or when the queue is full (the oldest goes). Messages are handed over in
the order they arrived, one at a time (the callback runs under the filter's lock).
"""
import collections
import threading
import time

import rospy

from .tf_wait import TF_ERRORS


# Messages waiting at most by default, as amcl's tf MessageFilter: 2.5 s of a 40 Hz laser.
# With 10, a /tf thread lagging 60 ms of wall time at 4x under load lost hundreds of scans.
QUEUE_SIZE = 100


class QueueOverflow(RuntimeError):
    """A message dropped from a full queue before its transform arrived."""


class TfMessageFilter:
    """Messages with header.stamp, handed over with the transform target <- source.

    buffer: tf2_ros.Buffer (any tf2.BufferCore); target, source: frame ids;
    callback(msg, transform): transform is a geometry_msgs/TransformStamped;
    on_error(msg, exc): a message given up (exc: one of tf_wait.TF_ERRORS or
    QueueOverflow); timeout [s of wall time]; queue_size: messages waiting at most;
    clock: wall clock [s] (tests pass their own).
    """

    def __init__(self, buffer, target, source, callback, on_error, timeout, queue_size=QUEUE_SIZE,
                 clock=time.monotonic):
        if queue_size < 1:
            raise ValueError(f"queue_size must be >= 1, got {queue_size}")
        self.buffer = buffer
        self.target, self.source = target, source
        self.callback, self.on_error = callback, on_error
        self.timeout = float(timeout)
        self.queue_size = int(queue_size)
        self.clock = clock
        self.lock = threading.RLock()
        self.queue = collections.deque()   # (msg, wall time it arrived [s])
        self.dropped = 0                   # messages given up, all reasons

    def add(self, msg):
        """A new message: handed over now if its transform is at hand, else queued."""
        with self.lock:
            if len(self.queue) >= self.queue_size:
                old, _ = self.queue.popleft()
                self._give_up(old, QueueOverflow(
                    f"queue of {self.queue_size} full: {self.target} <- {self.source} at "
                    f"{old.header.stamp.to_sec():.3f} did not arrive in time"))
            self.queue.append((msg, self.clock()))
            self._flush()

    def tf_arrived(self, _tf_msg=None):
        """New transforms are in the buffer: hand over what they make possible."""
        with self.lock:
            if self.queue:
                self._flush()

    def _flush(self):
        while self.queue:
            msg, arrived = self.queue[0]
            stamp = msg.header.stamp
            try:
                transform = self._lookup(stamp)
            except TF_ERRORS as e:
                if self.clock() - arrived < self.timeout and self._behind(stamp):
                    return  # on its way: wait for the next tf_arrived()
                self.queue.popleft()
                self._give_up(msg, e)
                continue
            self.queue.popleft()
            self.callback(msg, transform)

    def _lookup(self, stamp):
        """The transform at stamp. A failed lookup is asked once more when the newest
        transform already covers stamp: the listener's thread fills the buffer beside
        this one, and what covers stamp may have come in between."""
        try:
            return self.buffer.lookup_transform_core(self.target, self.source, stamp)
        except TF_ERRORS:
            if self._behind(stamp):
                raise
            return self.buffer.lookup_transform_core(self.target, self.source, stamp)

    def _behind(self, stamp):
        """True when the newest transform is older than stamp, or there is none yet (it
        may still come); False when waiting cannot help."""
        try:
            latest = self.buffer.lookup_transform_core(self.target, self.source, rospy.Time(0))
        except TF_ERRORS:
            return True
        return latest.header.stamp < stamp

    def _give_up(self, msg, exc):
        self.dropped += 1
        self.on_error(msg, exc)
