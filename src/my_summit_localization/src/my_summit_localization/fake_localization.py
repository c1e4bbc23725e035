"""fake_localization's arithmetic: a ground-truth pose becomes amcl's outputs (no rospy).

Reference: ROS navigation's fake_localization (fake_localization.cpp, I. Sucan; wiki.ros.org
/fake_localization). It stands in for amcl when the simulator knows the true pose: each
ground-truth pose (base_pose_ground_truth, in the simulator's world frame) is moved into
the map frame by a fixed offset, and the map -> odom transform is what makes
map -> odom -> base equal that pose, given odometry's odom -> base at the same instant:

    map_pose = offset (+) truth
    map_to_odom = map_pose (+) inverse(odom_to_base)

The offset starts as fake_localization's ``tf::Transform(rot(-delta_yaw), (-delta_x,
-delta_y))``, i.e. the pose (-delta_x, -delta_y, -delta_yaw): delta_* is where the map
frame's origin sits in the simulator's frame, as the real node reads it (its rotation
applied after its translation, exactly as there). An initialpose message re-bases it so that the
current pose becomes the given one (fake_localization >= 1.1.3:
``offset = initial_pose * inverse(current map pose) * offset``).

Poses are (x [m], y [m], yaw [rad]) numpy arrays.
"""
import numpy as np

from .particle_filter import compose, inverse


def offset_from_deltas(delta_x, delta_y, delta_yaw):
    """The world -> map offset pose (3,) of fake_localization's ~delta_x [m], ~delta_y [m],
    ~delta_yaw [rad] parameters."""
    return np.array([-float(delta_x), -float(delta_y), -float(delta_yaw)])


class FakeLocalizer:
    """Ground truth in, map pose and map -> odom out.

    offset: initial world -> map offset pose (3,) (see offset_from_deltas).
    """

    def __init__(self, offset=(0.0, 0.0, 0.0)):
        self.offset = np.asarray(offset, dtype=np.float64).copy()
        self.pose = None          # last map pose (3,), None before the first update

    def update(self, truth_pose, odom_to_base):
        """(map pose (3,), map -> odom (3,)) of a ground-truth pose (3,) in the world frame
        and odometry's odom -> base (3,) at the same instant."""
        truth = np.asarray(truth_pose, dtype=np.float64)
        if not np.all(np.isfinite(truth)) or not np.all(np.isfinite(odom_to_base)):
            raise ValueError(f"non-finite pose: truth {truth.tolist()}, odom {list(odom_to_base)}")
        self.pose = compose(self.offset, truth)
        return self.pose.copy(), compose(self.pose, inverse(np.asarray(odom_to_base, dtype=np.float64)))

    def set_pose(self, pose):
        """Re-base the offset so that the current pose becomes `pose` (3,) (initialpose).

        ValueError before the first update (there is no current pose to move) or on a
        non-finite pose."""
        pose = np.asarray(pose, dtype=np.float64)
        if not np.all(np.isfinite(pose)):
            raise ValueError(f"non-finite initial pose {pose.tolist()}")
        if self.pose is None:
            raise ValueError("no ground-truth pose received yet")
        correction = compose(pose, inverse(self.pose))
        self.offset = compose(correction, self.offset)
        self.pose = pose.copy()

