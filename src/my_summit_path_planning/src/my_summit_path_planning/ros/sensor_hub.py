"""The obstacle layers' sensor subscriptions: the latest reading of each topic.

Reference: costmap_2d's ``observation_buffer.cpp`` and the obstacle layer's
subscribers (``obstacle_layer.cpp``: one per observation source, queue 50, by the
source's data_type).
"""
import threading

import rospy
from rospy.numpy_msg import numpy_msg
from sensor_msgs.msg import LaserScan, PointCloud, PointCloud2
from summit_nav_common.ros.scan_stats import ScanStats


class SensorHub:
    """The latest reading (LaserScan, PointCloud2 or PointCloud) of each topic, taken once by
    each obstacle layer.

    costmap_2d's observation buffers with observation_persistence 0 keep only the most
    recent reading; so does this, and each layer sees a reading at most once. Readings
    replaced before an update used them are that design; readings lost before they reach
    _cb (the subscriber fell behind) are counted on ~scans_skipped (stats: a ScanStats,
    or what counts them in a test: observe(topic, header)).
    """

    MESSAGES = {"LaserScan": numpy_msg(LaserScan), "PointCloud2": numpy_msg(PointCloud2),
                "PointCloud": PointCloud}

    def __init__(self, stats=None):
        self.lock = threading.Lock()
        self.latest = {}   # topic -> msg
        self.types = {}    # topic -> data_type
        self.seen = {}     # (topic, layer id) -> msg already used
        self.stats = ScanStats("move_base") if stats is None else stats   # readings lost before _cb

    def watch(self, topic, data_type):
        """Subscribe to topic (once); ValueError when it is already watched as another type."""
        if topic in self.types:
            if self.types[topic] != data_type:
                raise ValueError(f"topic {topic} is read as {self.types[topic]} by another source, "
                                 f"here as {data_type}")
            return
        self.types[topic] = data_type
        self.latest[topic] = None
        # costmap_2d's observation subscribers queue 50: every reading reaches _cb, so a gap
        # in header.seq there means the node was starved, not that a newer one replaced it
        rospy.Subscriber(topic, self.MESSAGES[data_type], lambda m, t=topic: self._cb(t, m), queue_size=50,
                         buff_size=1 << 22)

    def _cb(self, topic, msg):
        self.stats.observe(topic, msg.header)
        with self.lock:
            self.latest[topic] = msg

    def take(self, topic, who):
        """The latest reading of topic if who (a layer's key) has not taken it yet, else None."""
        with self.lock:
            msg = self.latest.get(topic)
            if msg is None or self.seen.get((topic, who)) is msg:
                return None
            self.seen[(topic, who)] = msg
            return msg
