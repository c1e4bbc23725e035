"""The multi-robot lesson's small logic, without rospy: robot ids, goals from parameters,
pose errors.

A robot's id is its namespace and its frame prefix: ``robot_N`` (the simulator's names).
The send_goal node takes it as its argument (``robot_0``, or just ``0``); its goal comes
from the parameters goal_x [m], goal_y [m], goal_theta [deg] in the map frame, as in the
course's lesson.
"""
import math
import re

from my_summit_localization.spots import Spot

# A ROS graph name's base: a letter, then letters, digits, underscores (REP 135 / names).
_ROBOT_NAME = re.compile(r"^[A-Za-z][A-Za-z0-9_]*$")


class GoalError(ValueError):
    """A robot id or a goal parameter that cannot be used; the text says why."""


def robot_namespace(robot_id):
    """The robot's namespace name (no slashes) of a command-line id.

    'robot_0' -> 'robot_0'; '3' -> 'robot_3'; a leading or trailing '/' is ignored.
    GoalError for an empty id or one that is not a ROS name.
    """
    rid = str(robot_id).strip().strip("/")
    if not rid:
        raise GoalError("the robot id is empty (expected robot_N or N)")
    if rid.isdigit():
        return f"robot_{int(rid)}"
    if not _ROBOT_NAME.match(rid):
        raise GoalError(f"robot id '{robot_id}' is not a ROS name (expected robot_N or N)")
    return rid


def goal_spot(goal_x, goal_y, goal_theta_deg):
    """Spot of the goal parameters goal_x [m], goal_y [m], goal_theta [deg].

    GoalError naming the parameter when one is missing (None), not a number, or not finite.
    """
    values = []
    for name, v in (("goal_x", goal_x), ("goal_y", goal_y), ("goal_theta", goal_theta_deg)):
        if v is None:
            raise GoalError(f"parameter {name} is not set")
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise GoalError(f"parameter {name} = {v!r} is not a number")
        if not math.isfinite(v):
            raise GoalError(f"parameter {name} = {v!r} is not finite")
        values.append(float(v))
    return Spot.from_xy_yaw(values[0], values[1], math.radians(values[2]))


def robots_param(robots):
    """The simulator's ``robots`` parameter text of [(name, x [m], y [m], yaw [rad]), ...]."""
    return "[" + ", ".join(f"{{name: {n}, x: {x:.6g}, y: {y:.6g}, yaw: {yaw:.6g}}}"
                           for n, x, y, yaw in robots) + "]"
