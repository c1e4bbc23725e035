"""Publishing from a node's own thread while rospy shuts down.

ROS plumbing shared by the nodes that publish from a loop of their own (slam_gmapping's
map->odom broadcaster, move_base's costmap publisher). Such a loop checks
``rospy.is_shutdown()`` and then publishes; shutdown can close the topic in between, and
the publish raises "publish() to a closed topic". rospy.core.signal_shutdown closes every
topic in a pre-shutdown hook (the registration manager's cleanup) *before*
``is_shutdown()`` turns true, so that check cannot tell this case apart;
``rospy.core.is_shutdown_requested()`` is already true then.
"""
import rospy


def publish_or_end(publish, *args):
    """Call publish(*args). Returns True when it went out, False when rospy's shutdown
    had closed the topic (the caller's loop should end quietly); a closed topic while the
    node is running is raised."""
    try:
        publish(*args)
    except rospy.ROSException:
        if rospy.core.is_shutdown_requested():
            return False
        raise
    return True
