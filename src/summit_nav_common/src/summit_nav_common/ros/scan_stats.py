"""How many scans a node never processed because it fell behind.

amcl, slam_gmapping and move_base's costmaps take scans through a short subscriber queue,
so a node that cannot keep up loses scans without a word. ScanStats counts them from
header.seq (summit_nav_common.seq_gaps) at the top of the scan callback, and the scans
the node itself gives up from a full queue of its own (drop()), and reports:
- ``~scans_skipped`` (std_msgs/UInt32, latched): the total over the node's scan topics,
  published at once and then within a second of each change;
- one warning the first time a topic skips, with the gap seen;
- one line at shutdown per topic: received and skipped.
"""
import threading
import time

import rospy
from std_msgs.msg import UInt32

from ..seq_gaps import SeqGaps
from .shutdown import publish_or_end

PUBLISH_PERIOD = 1.0  # [s of wall time] the topic is refreshed at most this often


class ScanStats:
    def __init__(self, node_label: str):
        self.label = node_label
        self.lock = threading.Lock()
        self.topics = {}          # topic -> SeqGaps
        self.published = None    # the total last published
        self.pub = rospy.Publisher("~scans_skipped", UInt32, queue_size=1, latch=True)
        self.pub.publish(UInt32(0))
        self.published = 0
        threading.Thread(target=self._loop, daemon=True).start()
        rospy.on_shutdown(self._summary)

    def observe(self, topic: str, header) -> int:
        """Count one scan of topic (its std_msgs/Header); returns the scans skipped before it."""
        with self.lock:
            gaps = self.topics.setdefault(topic, SeqGaps())
            first = gaps.skipped == 0
            last = gaps.last
            gap = gaps.observe(header.seq)
        if gap and first:
            rospy.logwarn(f"{self.label}: fell behind on {topic}: {gap} scan(s) skipped (header.seq "
                          f"{last} -> {header.seq}); the running count is on "
                          f"{rospy.resolve_name('~scans_skipped')}")
        return gap

    def drop(self, topic: str, where: str) -> None:
        """Count one scan of topic received and then given up from the full queue `where`."""
        with self.lock:
            gaps = self.topics.setdefault(topic, SeqGaps())
            first = gaps.dropped == 0
            gaps.drop()
        if first:
            rospy.logwarn(f"{self.label}: fell behind on {topic}: a scan dropped from {where}; the "
                          f"running count is on {rospy.resolve_name('~scans_skipped')}")

    @property
    def skipped(self) -> int:
        with self.lock:
            return sum(g.skipped for g in self.topics.values())

    def _loop(self):
        # wall time: a loop on ROS time stalls when the simulator does
        while not rospy.core.is_shutdown_requested():
            time.sleep(PUBLISH_PERIOD)
            self._refresh()

    def _refresh(self):
        total = self.skipped
        if total != self.published and publish_or_end(self.pub.publish, UInt32(total)):
            self.published = total

    def _summary(self):
        with self.lock:
            lines = [f"{t}: {g.received} received, {g.skipped} skipped"
                     + (f" ({g.dropped} of them from the node's queues)" if g.dropped else "")
                     for t, g in sorted(self.topics.items())]
        if lines:
            rospy.loginfo(f"{self.label}: scans at shutdown: " + "; ".join(lines))
