"""Unit tests of the multi-robot lesson's logic (robot ids, goals from parameters); no ROS master."""
import math

import pytest

from summit_nav_common.geometry import pose_error

from my_summit_navigation.multi_robot import GoalError, goal_spot, robot_namespace, robots_param


def test_robot_ids():
    assert robot_namespace("robot_0") == "robot_0"
    assert robot_namespace("/robot_1/") == "robot_1"
    assert robot_namespace("3") == "robot_3"
    for bad in ("", "  ", "robot-0", "1robot", "a/b"):
        with pytest.raises(GoalError):
            robot_namespace(bad)


def test_goal_from_parameters_in_degrees():
    s = goal_spot(10.12, 12.97, 45.0)
    assert (s.x, s.y) == (10.12, 12.97)
    assert s.yaw == pytest.approx(math.radians(45.0))
    assert goal_spot(6.32, 17.67, 0).yaw == pytest.approx(0.0)


@pytest.mark.parametrize("args, word", [((None, 1.0, 0.0), "goal_x is not set"), ((1.0, "a", 0.0), "goal_y"),
                                        ((1.0, 1.0, math.nan), "goal_theta"), ((True, 1.0, 0.0), "goal_x")])
def test_bad_goal_parameters_are_named(args, word):
    with pytest.raises(GoalError, match=word):
        goal_spot(*args)


def test_pose_error_wraps_yaw_and_robots_param():
    d, a = pose_error((1.0, 1.0, math.pi - 0.1), (1.0, 2.0, -math.pi + 0.1))
    assert d == pytest.approx(1.0) and a == pytest.approx(0.2)
    assert robots_param([("robot_0", 9.5, 14.5, 0.5)]) == "[{name: robot_0, x: 9.5, y: 14.5, yaw: 0.5}]"
