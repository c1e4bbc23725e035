"""move_base goals from spots: the one place a Spot becomes a MoveBaseGoal; and the wait
for simulated time both command-line clients need before their first ROS-time timeout."""
import time

from move_base_msgs.msg import MoveBaseGoal

CLOCK_POLL = 0.05     # [s] wall: poll of /clock before the first ROS-time wait


def wait_clock(timeout):
    """True once ROS time runs (under use_sim_time it is 0 until /clock starts, and a
    ROS-time timeout started then would end at once); waits up to timeout [s] wall."""
    import rospy
    end = time.monotonic() + timeout
    while rospy.Time.now().is_zero():
        if time.monotonic() > end or rospy.is_shutdown():
            return False
        time.sleep(CLOCK_POLL)
    return True


def move_base_goal(spot, frame_id, stamp):
    """MoveBaseGoal at a Spot (position and quaternion) in frame_id, stamped `stamp`."""
    g = MoveBaseGoal()
    g.target_pose.header.frame_id = frame_id
    g.target_pose.header.stamp = stamp
    p, o = g.target_pose.pose.position, g.target_pose.pose.orientation
    p.x, p.y, p.z = spot.x, spot.y, spot.z
    o.x, o.y, o.z, o.w = spot.qx, spot.qy, spot.qz, spot.qw
    return g
