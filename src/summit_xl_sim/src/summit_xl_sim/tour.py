"""Waypoint follower for the tour driver: the student at the keyboard, automated.

A turn-then-drive controller on ground truth (no planning: the waypoints are chosen so
the straight lines between them are clear). Heading error above ``turn_in_place``
rotates in place; otherwise drives with speed falling off near the waypoint and with
the heading error, steering proportionally. Pure function: pose in, command out.
"""
import math
from dataclasses import dataclass

from summit_nav_common.geometry import wrap_angle


@dataclass
class TourParams:
    """Gains and limits of the tour driver."""

    max_speed: float = 0.6         # [m/s] forward speed on straight stretches
    max_turn: float = 1.0          # [rad/s]
    k_heading: float = 2.0         # [1/s] turn rate per rad of heading error
    k_speed: float = 1.0           # [1/s] speed per metre of distance left
    turn_in_place: float = 0.6     # heading error [rad] above which the robot turns on the spot
    reached: float = 0.15          # distance [m] at which a waypoint counts as reached


def tour_command(params, pose, target):
    """(vx [m/s], wz [rad/s], reached) driving from pose (x, y, yaw) to target (x, y)."""
    dx, dy = target[0] - pose[0], target[1] - pose[1]
    dist = math.hypot(dx, dy)
    if dist < params.reached:
        return 0.0, 0.0, True
    err = wrap_angle(math.atan2(dy, dx) - pose[2])
    wz = max(-params.max_turn, min(params.max_turn, params.k_heading * err))
    if abs(err) > params.turn_in_place:
        return 0.0, wz, False
    vx = min(params.max_speed, params.k_speed * dist + 0.1) * math.cos(err)
    return max(0.0, vx), wz, False
