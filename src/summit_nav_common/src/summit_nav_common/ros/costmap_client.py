"""A costmap as costmap_2d publishes it, kept whole: the grid on <topic>
(nav_msgs/OccupancyGrid), sent once and again when its size or origin changes, and the
changed windows on <topic>_updates (map_msgs/OccupancyGridUpdate) in between, as
move_base's costmaps send them unless always_send_full_costmap is set. rviz's Map display
and explore_lite's Costmap2DClient read them the same way.
"""
import threading

import numpy as np
import rospy
from map_msgs.msg import OccupancyGridUpdate
from nav_msgs.msg import OccupancyGrid
from rospy.numpy_msg import numpy_msg


def apply_update(grid, x, y, width, height, values):
    """Write an OccupancyGridUpdate's window into grid ((H, W) int8, in place). False,
    writing nothing, when the window does not lie inside the grid or the values do not
    fill it."""
    values = np.asarray(values, dtype=np.int8).reshape(-1)
    h, w = grid.shape
    if x < 0 or y < 0 or width < 0 or height < 0 or x + width > w or y + height > h \
            or values.size != width * height:
        return False
    grid[y:y + height, x:x + width] = values.reshape(height, width)
    return True


class CostmapClient:
    """The latest whole costmap of a costmap topic and its _updates topic.

    snapshot() -> (header, info, data) with data an (H, W) int8 copy, or None before the
    first whole grid; on_change(client), when given, is called after each message is
    applied (in the subscriber's thread). An update whose window does not fit the grid is
    dropped with a warning; the next whole grid puts it right. (One sent for an older grid
    of the same size cannot be told apart, here as in rviz; move_base sends a whole grid
    whenever the size or origin changes.)
    """

    def __init__(self, topic, on_change=None):
        self.lock = threading.Lock()
        self.header = self.info = self.data = None
        self.version = 0          # messages applied
        self.on_change = on_change
        self.topic = rospy.resolve_name(topic)
        rospy.Subscriber(self.topic, numpy_msg(OccupancyGrid), self._on_grid, queue_size=1, buff_size=2 ** 25)
        rospy.Subscriber(self.topic + "_updates", numpy_msg(OccupancyGridUpdate), self._on_update,
                         queue_size=10, buff_size=2 ** 24)

    def _on_grid(self, msg):
        data = np.asarray(msg.data, dtype=np.int8).reshape(msg.info.height, msg.info.width).copy()
        with self.lock:
            self.header, self.info, self.data = msg.header, msg.info, data
            self.version += 1
        if self.on_change is not None:
            self.on_change(self)

    def _on_update(self, msg):
        with self.lock:
            if self.data is None:
                return
            if not apply_update(self.data, msg.x, msg.y, msg.width, msg.height, msg.data):
                rospy.logwarn_throttle(10.0, f"{self.topic}_updates: window ({msg.x}, {msg.y}) "
                                             f"{msg.width} x {msg.height} does not fit the "
                                             f"{self.data.shape[1]} x {self.data.shape[0]} grid: dropped")
                return
            self.header = msg.header
            self.version += 1
        if self.on_change is not None:
            self.on_change(self)

    def snapshot(self):
        """(header, info, (H, W) int8 copy) of the costmap now, or None before the first grid."""
        with self.lock:
            if self.data is None:
                return None
            return self.header, self.info, self.data.copy()
