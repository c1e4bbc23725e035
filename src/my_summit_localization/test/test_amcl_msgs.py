"""Unit tests of the amcl node's message conversions (no ROS master)."""
import math

import numpy as np
import pytest
from geometry_msgs.msg import PoseWithCovarianceStamped

from my_summit_localization import amcl_msgs


def initialpose(frame="map", x=1.0, y=2.0, yaw=0.5, cov=(0.25, 0.25, 0.07), xy=0.0):
    msg = PoseWithCovarianceStamped()
    msg.header.frame_id = frame
    msg.pose.pose.position.x, msg.pose.pose.position.y = x, y
    msg.pose.pose.orientation.z, msg.pose.pose.orientation.w = math.sin(yaw / 2), math.cos(yaw / 2)
    c = [0.0] * 36
    c[0], c[7], c[35], c[1], c[6] = cov[0], cov[1], cov[2], xy, xy
    msg.pose.covariance = c
    return msg


def test_initialpose_in_the_global_frame():
    mean, cov, warning = amcl_msgs.initial_pose_from_msg(initialpose(xy=0.01), "map")
    np.testing.assert_allclose(mean, [1.0, 2.0, 0.5])
    np.testing.assert_allclose(cov, [[0.25, 0.01, 0], [0.01, 0.25, 0], [0, 0, 0.07]])
    assert warning is None
    assert amcl_msgs.initial_pose_from_msg(initialpose("/map"), "map")[2] is None


def test_initialpose_empty_frame_is_taken_with_a_warning():
    _, _, warning = amcl_msgs.initial_pose_from_msg(initialpose(""), "map")
    assert "empty frame_id" in warning


@pytest.mark.parametrize("msg, why", [
    (initialpose("odom"), "frame 'odom' ignored"),
    (initialpose(x=float("nan")), "NaN"),
    (initialpose(y=float("inf")), "NaN"),
    (initialpose(cov=(float("nan"), 0.1, 0.1)), "NaN"),
    (initialpose(cov=(-1.0, 0.1, 0.1)), "positive semi-definite"),
])
def test_bad_initialpose_is_refused(msg, why):
    with pytest.raises(amcl_msgs.InitialPoseError, match=why):
        amcl_msgs.initial_pose_from_msg(msg, "map")


def test_bad_initialpose_asymmetric_and_zero_quaternion():
    msg = initialpose()
    c = list(msg.pose.covariance)
    c[1] = 0.1
    msg.pose.covariance = c
    with pytest.raises(amcl_msgs.InitialPoseError, match="symmetric"):
        amcl_msgs.initial_pose_from_msg(msg, "map")
    msg = initialpose()
    msg.pose.pose.orientation.w = 0.0
    msg.pose.pose.orientation.z = 0.0
    with pytest.raises(amcl_msgs.InitialPoseError, match="zero quaternion"):
        amcl_msgs.initial_pose_from_msg(msg, "map")


def test_pose_with_covariance_layout():
    cov = np.array([[0.1, 0.02, 0.003], [0.02, 0.2, 0.004], [0.003, 0.004, 0.05]])
    msg = amcl_msgs.pose_with_covariance_msg((1.0, -2.0, math.pi / 2), cov, "map")
    c = np.array(msg.pose.covariance).reshape(6, 6)
    np.testing.assert_allclose(c[np.ix_([0, 1, 5], [0, 1, 5])], cov)
    assert np.count_nonzero(c) == 9
    np.testing.assert_allclose(amcl_msgs.pose_of_pose_msg(msg.pose.pose), [1.0, -2.0, math.pi / 2])
    assert msg.header.frame_id == "map"


@pytest.mark.parametrize("n", [0, 1, 777])
def test_pose_array_block_is_the_reference_message_on_the_wire(n):
    """PoseArrayBlock serializes to the same bytes as pose_array_msg (one Pose per
    particle, genpy's serializer), and reads back as a PoseArray of the particles."""
    from io import BytesIO

    import rospy
    from geometry_msgs.msg import PoseArray
    rng = np.random.default_rng(n)
    p = np.column_stack([rng.normal(size=n) * 10, rng.normal(size=n), rng.uniform(-math.pi, math.pi, n)])
    stamp = rospy.Time(12, 345)
    ref, fast = BytesIO(), BytesIO()
    amcl_msgs.pose_array_msg(p, "map", stamp).serialize(ref)
    block = amcl_msgs.PoseArrayBlock(p, "map", stamp)
    block.serialize(fast)
    assert fast.getvalue() == ref.getvalue()
    assert (block._type, block._md5sum) == (PoseArray._type, PoseArray._md5sum)
    back = PoseArray().deserialize(fast.getvalue())
    assert back.header.frame_id == "map" and back.header.stamp == stamp and len(back.poses) == n
    if n:
        np.testing.assert_allclose([amcl_msgs.pose_of_pose_msg(m) for m in back.poses], p, atol=1e-12)


def test_pose_array_and_transform():
    rng = np.random.default_rng(0)
    p = np.column_stack([rng.normal(size=50), rng.normal(size=50), rng.uniform(-math.pi, math.pi, 50)])
    msg = amcl_msgs.pose_array_msg(p, "map")
    back = np.array([amcl_msgs.pose_of_pose_msg(m) for m in msg.poses])
    np.testing.assert_allclose(back, p, atol=1e-12)
    t = amcl_msgs.transform_msg((0.5, -1.0, -2.0), "map", "odom")
    assert (t.header.frame_id, t.child_frame_id) == ("map", "odom")
    np.testing.assert_allclose(amcl_msgs.pose_of_transform(t.transform), [0.5, -1.0, -2.0])


def test_scan_angles():
    a = amcl_msgs.scan_angles(-2.356, 2 * 2.356 / 1080, 1081)
    assert a.shape == (1081,)
    np.testing.assert_allclose([a[0], a[540], a[-1]], [-2.356, 0.0, 2.356], atol=1e-12)
