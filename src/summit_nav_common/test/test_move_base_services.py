"""clear_costmaps: the service name under the move_base namespace, and a missing or failing
service costs a warning and False, never an exception."""
from unittest import mock

import rospy

from summit_nav_common.ros import move_base_services as mbs


def test_calls_the_service_under_the_namespace():
    with mock.patch.object(rospy, "wait_for_service") as wait, mock.patch.object(rospy, "ServiceProxy") as proxy:
        assert mbs.clear_costmaps("/robot_1/move_base", 2.0) is True
    wait.assert_called_once_with("/robot_1/move_base/clear_costmaps", 2.0)
    proxy.return_value.assert_called_once_with()


def test_missing_service_warns_and_returns_false():
    with mock.patch.object(rospy, "wait_for_service", side_effect=rospy.ROSException("timeout exceeded")), \
            mock.patch.object(rospy, "ServiceProxy") as proxy, mock.patch.object(rospy, "logwarn") as warn:
        assert mbs.clear_costmaps("/move_base", 0.1, who="explore: ") is False
    proxy.assert_not_called()
    text = warn.call_args[0][0]
    assert text.startswith("explore: could not clear the costmaps (/move_base/clear_costmaps)")
    assert "timeout exceeded" in text


def test_failing_call_warns_and_returns_false():
    with mock.patch.object(rospy, "wait_for_service"), mock.patch.object(rospy, "ServiceProxy") as proxy, \
            mock.patch.object(rospy, "logwarn") as warn:
        proxy.return_value.side_effect = rospy.ServiceException("service returned an error")
        assert mbs.clear_costmaps("/move_base") is False
    assert "service returned an error" in warn.call_args[0][0]
