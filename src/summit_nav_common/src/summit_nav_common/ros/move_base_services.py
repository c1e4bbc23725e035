"""Calls to move_base's services that the navigation scripts share."""
import rospy
from std_srvs.srv import Empty


def clear_costmaps(move_base="move_base", wait=5.0, who=""):
    """Call <move_base>/clear_costmaps (std_srvs/Empty), waiting up to `wait` [s] for it.

    True when it answered. A move_base that is not there or fails only costs a warning
    (prefixed with `who`): clearing is a retry's help, never a reason to stop the caller.
    """
    name = rospy.resolve_name(move_base) + "/clear_costmaps"
    try:
        rospy.wait_for_service(name, wait)
        rospy.ServiceProxy(name, Empty)()
        return True
    except (rospy.ROSException, rospy.ServiceException) as e:
        rospy.logwarn(f"{who}could not clear the costmaps ({name}): {e}")
        return False
