"""base_local_planner's oscillation flags: a motion just reversed may not be reversed again.

Reference: base_local_planner's OscillationCostFunction (setOscillationFlags,
resetOscillationFlagsIfPossible).
"""
import math

import numpy as np

from summit_nav_common.geometry import wrap_angle

class OscillationFlags:
    """base_local_planner's OscillationCostFunction: forbid reversing a motion just made."""

    NAMES = ("forward_pos", "forward_neg", "strafe_pos", "strafe_neg", "rot_pos", "rot_neg")

    def __init__(self, reset_dist, reset_angle):
        self.reset_dist = reset_dist
        self.reset_angle = reset_angle
        self.reset()
        self.prev_stationary = None

    def reset(self):
        """Clear all flags (new plan, or the robot moved far enough)."""
        for n in self.NAMES:
            setattr(self, n, False)
            setattr(self, n + "_only", False)

    def forbidden(self, samples):
        """(N,) bool: samples that would reverse a flagged motion."""
        vx, vy, w = samples[:, 0], samples[:, 1], samples[:, 2]
        bad = np.zeros(len(samples), dtype=bool)
        if self.forward_pos_only:
            bad |= vx < 0
        if self.forward_neg_only:
            bad |= vx > 0
        if self.strafe_pos_only:
            bad |= vy < 0
        if self.strafe_neg_only:
            bad |= vy > 0
        if self.rot_pos_only:
            bad |= w < 0
        if self.rot_neg_only:
            bad |= w > 0
        return bad

    def _set(self, v, pos, neg):
        flag = False
        if v < 0:
            if getattr(self, pos):
                setattr(self, neg + "_only", True)
                flag = True
            setattr(self, pos, False)
            setattr(self, neg, True)
        if v > 0:
            if getattr(self, neg):
                setattr(self, pos + "_only", True)
                flag = True
            setattr(self, neg, False)
            setattr(self, pos, True)
        return flag

    def update(self, pose, cmd, min_vel_trans):
        """After choosing cmd at pose: set flags on reversals, reset them once moved enough."""
        flag = self._set(cmd[0], "forward_pos", "forward_neg")
        if abs(cmd[0]) <= min_vel_trans:  # strafe / rotation flags only when not driving
            flag |= self._set(cmd[1], "strafe_pos", "strafe_neg")
            flag |= self._set(cmd[2], "rot_pos", "rot_neg")
        if flag or self.prev_stationary is None:
            self.prev_stationary = pose
        if any(getattr(self, n + "_only") for n in self.NAMES):
            px, py, pth = self.prev_stationary
            if (math.hypot(pose[0] - px, pose[1] - py) > self.reset_dist
                    or abs(wrap_angle(pose[2] - pth)) > self.reset_angle):
                self.reset()
