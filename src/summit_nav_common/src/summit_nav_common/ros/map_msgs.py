"""Conversions between nav_msgs/OccupancyGrid messages and summit_nav_common.map_io.GridMap.

The map nodes (map_server, map_saver, map_autosaver, slam_gmapping) share these so the
message layout is written once: data row-major from the lower-left cell (row 0 = lowest
y), origin = pose of cell (0, 0)'s lower-left corner with a yaw about z. No rospy here:
only the message classes (genpy), so the functions are unit-tested without a master.
"""
import numpy as np
from geometry_msgs.msg import Pose
from nav_msgs.msg import MapMetaData, OccupancyGrid

from summit_nav_common.geometry import quaternion_to_yaw, yaw_to_quaternion_zw
from summit_nav_common.map_io import GridMap


def make_metadata(width, height, resolution, origin, load_time=None):
    """nav_msgs/MapMetaData of a width x height [cells] grid, cell side resolution [m],
    origin (x [m], y [m], yaw [rad]); load_time: a rospy/genpy Time or None."""
    info = MapMetaData()
    if load_time is not None:
        info.map_load_time = load_time
    info.resolution = float(resolution)
    info.width, info.height = int(width), int(height)
    pose = Pose()
    pose.position.x, pose.position.y = float(origin[0]), float(origin[1])
    pose.orientation.z, pose.orientation.w = yaw_to_quaternion_zw(float(origin[2]))
    info.origin = pose
    return info


def grid_to_msg(grid, frame_id, stamp=None, msg_class=OccupancyGrid):
    """OccupancyGrid message of a GridMap (data stays a numpy int8 array when msg_class
    is a rospy.numpy_msg class, so it is serialized without a per-cell Python loop;
    otherwise it becomes a list as genpy expects)."""
    msg = msg_class()
    msg.header.frame_id = frame_id
    if stamp is not None:
        msg.header.stamp = stamp
    msg.info = make_metadata(grid.width, grid.height, grid.resolution, grid.origin, stamp)
    data = np.ascontiguousarray(grid.data, dtype=np.int8).reshape(-1)
    msg.data = data if msg_class is not OccupancyGrid else data.tolist()
    return msg


def msg_to_grid(msg):
    """GridMap of an OccupancyGrid message; ValueError when data and size disagree."""
    width, height = int(msg.info.width), int(msg.info.height)
    data = np.asarray(msg.data, dtype=np.int8) if not isinstance(msg.data, (bytes, bytearray)) \
        else np.frombuffer(msg.data, dtype=np.int8)
    if data.size != width * height:
        raise ValueError(f"OccupancyGrid has {data.size} cells but info says {width} x {height}")
    o = msg.info.origin
    origin = (o.position.x, o.position.y, quaternion_to_yaw(o.orientation))
    return GridMap(data=data.reshape(height, width).copy(), resolution=float(msg.info.resolution),
                   origin=origin)
