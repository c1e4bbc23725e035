"""carrot_planner/CarrotPlanner: a straight line to the goal, cut short at an obstacle.

Reference: ROS 1 navigation ``carrot_planner`` (wiki.ros.org/carrot_planner, its
makePlan). The plan has two poses, the start and a target on the segment from the start
to the goal: the goal itself when the robot's footprint is legal there, else the first
legal pose stepping back towards the start by 1 % of the segment at a time (position and
heading interpolated together). "Legal" is base_local_planner's CostmapModel footprint
check: the footprint's outline, rasterized edge by edge, touches no lethal or unknown
cell and lies on the costmap (trajectory_planner.footprint_costs, whose cell-by-cell
oracle is footprint_cost_reference). When no pose on the segment is legal the planner
fails, as the real one returns false.

It is meant for a goal the robot can see and drive to in a straight line, or for
approaching an obstacle as near as its footprint allows: it does not go around
anything. The real planner reads ``step_size`` (default: the costmap's resolution) and
``min_dist_from_robot`` (0.10 m) but never uses them; so does this one (they are
checked as numbers and otherwise have no effect).

Differs from the real node: move_base hands our local planners the goal's heading, not
the plan's last pose's; the two differ only when the target is short of the goal.
"""
import math

import numpy as np

from .global_plan import PlanResult
from .param_reader import FLOAT, Field, Schema
from .footprint_cost import footprint_cost_reference, footprint_costs
from summit_nav_common.geometry import wrap_angle


def _carrot_scales():
    """The real planner's scales: 1.0 less 0.01 at a time while >= 0 (the same doubles its
    loop produces, so the poses tried are the same ones)."""
    out, scale = [], 1.0
    while scale >= 0.0:
        out.append(scale)
        scale -= 0.01
    return np.array(out)


SCALES = _carrot_scales()
# the real planner's two parameters [m] (read, unused)
SCHEMA = Schema([Field("step_size", FLOAT, None, optional=True, what="a finite number [m]"),
                 Field("min_dist_from_robot", FLOAT, 0.10, what="a finite number [m]")])
KNOWN_PARAMS = tuple(SCHEMA.known)
NO_TARGET = "The carrot planner could not find a valid plan for this goal"


class CarrotPlanner:
    """The carrot planner (base_global_planner's makePlan, without ROS).

    footprint: the costmap's Footprint (its padded polygon is checked); step_size [m] or
    None (the costmap's resolution) and min_dist_from_robot [m]: read, unused, as the
    real planner's.
    """

    KNOWN_PARAMS = KNOWN_PARAMS

    def __init__(self, footprint, step_size=None, min_dist_from_robot=0.10):
        self.footprint = footprint
        self.step_size = step_size
        self.min_dist_from_robot = min_dist_from_robot
        self.notes = []   # param_reader Notes about its parameters

    @classmethod
    def from_params(cls, params, footprint, where="CarrotPlanner", note_where=None):
        """From the ~CarrotPlanner namespace (SCHEMA); ParamError on a value that is not a
        number; .notes: the names it does not read (prefixed with note_where, default where)."""
        r = SCHEMA.read(params, where, note_where)
        planner = cls(footprint, **r.values)
        planner.notes = r.notes
        return planner

    def targets(self, start, goal):
        """(M, 3) poses tried, goal first, then stepping back to the start."""
        sx, sy, syaw = (float(v) for v in start)
        gx, gy, gyaw = (float(v) for v in goal)
        dyaw = wrap_angle(gyaw - syaw)
        return np.column_stack([sx + SCALES * (gx - sx), sy + SCALES * (gy - sy),
                                wrap_angle(syaw + SCALES * dyaw)])

    def make_plan(self, costmap, start, goal, tolerance=None):
        """Plan on costmap from start to goal, each (x, y[, yaw]) [m, rad] (a missing yaw
        counts as 0). tolerance: unused (the real planner has none). Returns a PlanResult:
        path (2, 2), the start and the target, or None with the reason."""
        start, goal = _pose(start), _pose(goal)
        for what, p in (("start", start), ("goal", goal)):
            if not all(math.isfinite(v) for v in p):
                return PlanResult(reason=f"{what} {p} is not a finite pose")
        poses = self.targets(start, goal)
        legal = np.flatnonzero(footprint_costs(costmap, self.footprint.polygon,
                                               poses[:, 0], poses[:, 1], poses[:, 2]) >= 0.0)
        if legal.size == 0:
            return PlanResult(reason=NO_TARGET)
        target = poses[legal[0]]
        path = np.array([start[:2], target[:2]])
        return PlanResult(path=path, goal=(float(target[0]), float(target[1])),
                          length=float(math.hypot(*(target[:2] - np.asarray(start[:2])))))

    def make_plan_reference(self, costmap, start, goal):
        """The same, pose by pose with the cell-by-cell footprint check (test oracle)."""
        start, goal = _pose(start), _pose(goal)
        for pose in self.targets(start, goal):
            if footprint_cost_reference(costmap, self.footprint.polygon, *pose) >= 0.0:
                return tuple(float(v) for v in pose)
        return None


def _pose(p):
    p = tuple(float(v) for v in p)
    return p[:3] if len(p) >= 3 else p[:2] + (0.0,)

