"""What every local planner returns and holds (nav_core's BaseLocalPlanner side).

``DWAResult``: what compute_velocity returns (both local planners: DWA and
TrajectoryPlannerROS). ``HeldPlan``: the plan a local planner holds in the local frame,
re-expressed each cycle (move_base's transformGlobalPlan).
"""
from dataclasses import dataclass, field

import numpy as np

from summit_nav_common.geometry import transform_points, wrap_angle

@dataclass
class DWAResult:
    """What compute_velocity returns.

    cmd: (vx [m/s], vy [m/s], vth [rad/s]); ok: False when no valid command exists
    (reason says why; cmd is then zero); goal_reached; trajectory: (T, 3) poses of the
    chosen sample (x, y, yaw) or None; n_valid / n_samples; cost of the chosen sample;
    mode: 'dwa', 'escape', 'stop', 'rotate' or 'goal'.
    """

    cmd: tuple = (0.0, 0.0, 0.0)
    ok: bool = True
    reason: str = ""
    goal_reached: bool = False
    trajectory: np.ndarray = field(default=None, repr=False)
    n_valid: int = 0
    n_samples: int = 0
    cost: float = 0.0
    mode: str = "dwa"


class HeldPlan:
    """What both local planners do with the plan they hold: self.plan ((N, 2) points in the
    local frame, or None) and self.goal_yaw [rad], re-expressed by reframe_plan."""

    def reframe_plan(self, delta):
        """nav_core's LocalPlanner.reframe_plan (transformGlobalPlan, each cycle): the plan
        (as pruned) and goal heading re-expressed by the rigid transform delta (x [m],
        y [m], yaw [rad]); the goal latch and the pruning are kept."""
        if self.plan is None:
            return
        self.plan = transform_points(self.plan, delta)
        self.goal_yaw = float(wrap_angle(self.goal_yaw + delta[2]))
