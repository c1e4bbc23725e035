"""Waiting for a transform at a message's stamp in wall time, never in ROS time.

ROS plumbing shared by the nodes that look a transform up inside a subscriber callback
(slam_gmapping, amcl, fake_localization, move_base's obstacle layers). tf2's
``lookup_transform(..., timeout)`` waits in ROS time, i.e. on /clock. Our simulator
publishes synchronously: when one subscriber's socket is full it stops, and with it /clock
and the odometry tf. A callback waiting in ROS time for a transform only the simulator can
send, while its own socket fills because it is not reading, then waits forever (a CI
mapping tour froze 5 minutes at t = 38 s). So the wait here is bounded in wall time, and
only lasts while the newest transform is older than the stamp (the one asked for is
still on its way); any other failure is raised at once.
"""
import time

import rospy
import tf2_ros

# InvalidArgumentException: a message whose frame_id is empty or not a frame name
TF_ERRORS = (tf2_ros.LookupException, tf2_ros.ConnectivityException, tf2_ros.ExtrapolationException,
             tf2_ros.InvalidArgumentException)
POLL = 0.002   # [s] between lookups while waiting


def behind(buffer, target, source, stamp):
    """True when the newest transform target <- source is older than stamp (or there is
    none yet)."""
    try:
        latest = buffer.lookup_transform(target, source, rospy.Time(0))
    except TF_ERRORS:
        return True
    return latest.header.stamp < stamp


def lookup_at(buffer, target, source, stamp, wait):
    """buffer.lookup_transform(target, source, stamp), retried for up to wait [s] of wall
    time while the transform at stamp is still to come. Raises the last tf2 error (one of
    TF_ERRORS) when it cannot be had."""
    deadline = time.monotonic() + wait
    while True:
        try:
            return buffer.lookup_transform(target, source, stamp)
        except TF_ERRORS:
            if time.monotonic() < deadline and behind(buffer, target, source, stamp):
                time.sleep(POLL)
                continue
            raise
