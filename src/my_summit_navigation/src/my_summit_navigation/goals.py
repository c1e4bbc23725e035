"""move_base goals from spots: the one place a Spot becomes a MoveBaseGoal."""
from move_base_msgs.msg import MoveBaseGoal


def move_base_goal(spot, frame_id, stamp):
    """MoveBaseGoal at a Spot (position and quaternion) in frame_id, stamped `stamp`."""
    g = MoveBaseGoal()
    g.target_pose.header.frame_id = frame_id
    g.target_pose.header.stamp = stamp
    p, o = g.target_pose.pose.position, g.target_pose.pose.orientation
    p.x, p.y, p.z = spot.x, spot.y, spot.z
    o.x, o.y, o.z, o.w = spot.qx, spot.qy, spot.qz, spot.qw
    return g
