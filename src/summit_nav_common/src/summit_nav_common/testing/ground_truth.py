"""The simulator's ground truth in the map frame of the committed map, for rostests and
benchmarks that judge a node by where the robot really is.

Frames: /base_pose_ground_truth is in the simulator's world frame; the committed map
(my_summit_mapping/maps/my_map.yaml) was made from the default spawn pose, so its map
frame is the world frame moved to that pose: map_pose = inverse(map_in_world) (+)
world_pose, where map_in_world is nominally the spawn pose (the test node's
~map_in_world_x/y/yaw, default the simulator's /summit_xl_sim/x, y, yaw) refined by
registering the map against the world (register_map: the SLAM map is a few cm and a
fraction of a degree off the nominal frame).
"""
import math
import threading

import rospy
from nav_msgs.msg import Odometry
from std_msgs.msg import UInt32

from summit_nav_common.geometry import compose, inverse, quaternion_to_yaw
from summit_nav_common.geometry import pose_error  # noqa: F401  (the tests' gt.pose_error of poses in the map)
from summit_nav_common.testing.waits import wait_for


def spawn_in_world():
    """(x, y, yaw) of the map frame in the world, nominally: ~map_in_world_x/y/yaw, default
    the simulator's spawn parameters /summit_xl_sim/x, y, yaw."""
    return tuple(float(rospy.get_param("~map_in_world_" + k, rospy.get_param("/summit_xl_sim/" + k)))
                 for k in ("x", "y", "yaw"))


def map_in_world():
    """(x, y, yaw) of the committed map's frame in the simulator's world: spawn_in_world()
    refined by register_map (unless ~register_map is false). The map is ~map_file
    (default my_summit_mapping's maps/my_map.yaml), the world /summit_xl_sim/world."""
    guess = spawn_in_world()
    if not rospy.get_param("~register_map", True):
        return guess
    import rospkg
    default_map = rospkg.RosPack().get_path("my_summit_mapping") + "/maps/my_map.yaml"
    found = register_map(rospy.get_param("~map_file", default_map), rospy.get_param("/summit_xl_sim/world"), guess)
    rospy.loginfo(f"map frame in the world: nominal {tuple(round(v, 3) for v in guess)}, registered "
                  f"({found[0]:.3f}, {found[1]:.3f}, {math.degrees(found[2]):.2f} deg)")
    return found


def truth_in_map(odom_msg, m_in_w):
    """(x, y, yaw) in the map frame of a /base_pose_ground_truth message."""
    p = odom_msg.pose.pose
    world = (p.position.x, p.position.y, quaternion_to_yaw(p.orientation))
    return compose(inverse(m_in_w), world)


def world_to_map(m_in_w, x, y):
    """A world point (x, y) [m] in the map frame."""
    p = compose(inverse(m_in_w), (x, y, 0.0))
    return p[0], p[1]


def map_to_world(m_in_w, x, y):
    """A map-frame point (x, y) [m] in the world frame."""
    p = compose(m_in_w, (x, y, 0.0))
    return p[0], p[1]


class Truth:
    """Ground truth (in the map frame), the collision count and the driven track."""

    def __init__(self, m_in_w):
        self.m_in_w = m_in_w
        self.lock = threading.Lock()
        self.pose = None           # (x, y, yaw) map frame
        self.track = []            # [(t, x, y)] map frame
        self.collisions = 0
        self.coll_msgs = 0
        rospy.Subscriber("/base_pose_ground_truth", Odometry, self._on_truth, queue_size=20)
        rospy.Subscriber("/collisions", UInt32, self._on_coll, queue_size=5)

    def _on_truth(self, msg):
        p = truth_in_map(msg, self.m_in_w)
        with self.lock:
            self.pose = p
            if not self.track or math.hypot(p[0] - self.track[-1][1], p[1] - self.track[-1][2]) > 0.02:
                self.track.append((msg.header.stamp.to_sec(), p[0], p[1]))

    def _on_coll(self, msg):
        with self.lock:
            self.collisions = max(self.collisions, msg.data)
            self.coll_msgs += 1

    def wait(self):
        wait_for(lambda: self.pose is not None, "ground truth on /base_pose_ground_truth")
        return self.pose


def register_map(map_yaml, world_yaml, guess, span=0.15, step=0.01, span_yaw_deg=0.6,
                 step_yaw_deg=0.1, max_dist=0.3):
    """(x, y, yaw) of the map frame in the world: `guess` refined by registering the maps.

    A SLAM map is not exactly the world moved to the spawn pose: gmapping's estimate of
    the first poses leaves it rotated and shifted a little (the committed map: ~0.2 deg
    and a few cm), which 15 m from the origin makes several cm. The tests measure amcl
    against ground truth in the map amcl uses, so they take the map frame's pose in the
    world from the maps themselves: the map's occupied cell centres are placed in the
    world's distance field (bilinear, capped at max_dist [m]) and the mean squared
    distance is minimised over a grid of +-span [m] (step) and +-span_yaw_deg (step)
    around guess (a grid search: ICP between two cell lattices sticks at whole cells).
    """
    import numpy as np
    from scipy import ndimage
    from summit_nav_common.map_io import load_map

    world, m = load_map(world_yaml), load_map(map_yaml)
    dist = ndimage.distance_transform_edt(world.data != 100) * world.resolution
    np.minimum(dist, max_dist, out=dist)
    rows, cols = np.nonzero(m.data == 100)
    ox, oy, oa = m.origin
    mx, my = (cols + 0.5) * m.resolution, (rows + 0.5) * m.resolution
    c, s = math.cos(oa), math.sin(oa)
    src = np.column_stack([ox + c * mx - s * my, oy + s * mx + c * my])
    wx, wy, wa = world.origin
    cw, sw = math.cos(wa), math.sin(wa)

    def cost(x, y, a):
        c, s = math.cos(a), math.sin(a)
        px, py = x + c * src[:, 0] - s * src[:, 1] - wx, y + s * src[:, 0] + c * src[:, 1] - wy
        u = (cw * px + sw * py) / world.resolution - 0.5   # cell-centre coordinates
        v = (-sw * px + cw * py) / world.resolution - 0.5
        i0, j0 = np.floor(v).astype(int), np.floor(u).astype(int)
        fv, fu = v - i0, u - j0
        ok = (i0 >= 0) & (j0 >= 0) & (i0 < dist.shape[0] - 1) & (j0 < dist.shape[1] - 1)
        i0, j0, fv, fu = i0[ok], j0[ok], fv[ok], fu[ok]
        d = ((1 - fv) * ((1 - fu) * dist[i0, j0] + fu * dist[i0, j0 + 1])
             + fv * ((1 - fu) * dist[i0 + 1, j0] + fu * dist[i0 + 1, j0 + 1]))
        return (np.sum(d * d) + (src.shape[0] - d.size) * max_dist ** 2) / src.shape[0]

    best = None
    for da in np.arange(-span_yaw_deg, span_yaw_deg + 1e-9, step_yaw_deg):
        for dx in np.arange(-span, span + 1e-9, step):
            for dy in np.arange(-span, span + 1e-9, step):
                cand = (guess[0] + dx, guess[1] + dy, guess[2] + math.radians(da))
                e = cost(*cand)
                if best is None or e < best[0]:
                    best = (e, cand)
    return best[1]
