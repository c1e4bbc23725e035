#!/usr/bin/python3
"""rostest: dynamic_reconfigure of move_base's TrajectoryPlannerROS and GlobalPlanner.

move_base runs base_local_planner/TrajectoryPlannerROS and global_planner/GlobalPlanner
(the course's move_base.launch, the two planner types overridden); no ~DWAPlannerROS
server then. The robot's speed is measured on the simulator's ground truth (distance
over SPEED_WINDOW of sim time).

1. A goal 6 m along the hall at the YAML's max_vel_x 0.65: once the robot drives faster
   than FAST, max_vel_x is set to 0.3 through dynamic_reconfigure's client; from
   SETTLE later the running planner keeps the measured speed below 0.3 + SPEED_MARGIN;
   the goal is reached.
2. The next goal (a fresh planner, back along the hall): measured speed below the
   same bound all the way, and above 0.2 (it drove at the new limit).
3. Refused: max_vel_x 50 (out of the .cfg's range), sim_time 0 (the planner cannot run
   with it); restore_defaults brings back 0.65.
4. GlobalPlanner lethal_cost: ~make_plan to a goal in an inflated cell (costmap cost
   ~100..230) gives a plan at lethal_cost 253 and none at lethal_cost 60 (the cell is then
   an obstacle); cost_factor 9 (range [0.01, 5]) is refused. No collision.
"""
import math
import sys
import threading
import unittest

import numpy as np
import rospy
import rostest
from dynamic_reconfigure.client import Client
from geometry_msgs.msg import PoseStamped
from nav_msgs.msg import OccupancyGrid, Odometry
from nav_msgs.srv import GetPlan, GetPlanRequest

from summit_nav_common.testing import ground_truth as gt, move_base_client as mb, waits

FAST = 0.45          # [m/s] the robot is driving at the YAML's max_vel_x (0.65) before the change
SLOW = 0.3           # [m/s] the max_vel_x set
SPEED_WINDOW = 0.5   # [s] sim: the ground-truth speed is the distance over this
SPEED_MARGIN = 0.03  # [m/s] on the windowed speed (ground truth sampling, the base's response)
SETTLE = 1.0         # [s] sim after the change before the bound must hold


def windowed_speeds(samples, t_from=-math.inf, t_to=math.inf):
    """Speeds [m/s] over SPEED_WINDOW from [(t, x, y)] samples stamped in [t_from, t_to].

    One value per sample that has a later sample at least SPEED_WINDOW after it (the
    first such); empty when there is none (no sample yet, or a span below the window).
    """
    s = np.asarray(samples, dtype=float).reshape(-1, 3)
    s = s[(s[:, 0] >= t_from) & (s[:, 0] <= t_to)]
    j = np.searchsorted(s[:, 0], s[:, 0] + SPEED_WINDOW)
    ok = j < len(s)
    i, j = np.flatnonzero(ok), j[ok]
    d = np.hypot(s[j, 1] - s[i, 1], s[j, 2] - s[i, 2])
    return d / (s[j, 0] - s[i, 0])


class Speed:
    """Ground-truth speed: [(t_end, distance / SPEED_WINDOW)] over sliding windows."""

    def __init__(self):
        self.lock = threading.Lock()
        self.samples = []   # (t, x, y) world frame
        rospy.Subscriber("/base_pose_ground_truth", Odometry, self._on, queue_size=50)

    def _on(self, msg):
        p = msg.pose.pose.position
        with self.lock:
            self.samples.append((msg.header.stamp.to_sec(), p.x, p.y))

    def speeds(self, t_from=-math.inf, t_to=math.inf):
        with self.lock:
            samples = list(self.samples)
        return windowed_speeds(samples, t_from, t_to)

    def now(self):
        v = self.speeds(rospy.Time.now().to_sec() - 2 * SPEED_WINDOW)
        return float(v[-1]) if len(v) else 0.0


def served(namespace):
    """Whether a dynamic_reconfigure server publishes under namespace."""
    return any(t == f"{namespace}/parameter_updates" for t, _ in rospy.get_published_topics())


class ReconfigureTPR(unittest.TestCase):
    def test_reconfigure_trajectory_and_global_planner(self):
        rospy.init_node("move_base_reconfigure_tpr_test")
        waits.wait_clock()
        client = mb.client()
        truth = gt.Truth(gt.spawn_in_world())
        truth.wait()
        speed = Speed()
        tpr = Client("/move_base/TrajectoryPlannerROS", timeout=60)
        gp = Client("/move_base/GlobalPlanner", timeout=60)
        self.assertTrue(served("/move_base/TrajectoryPlannerROS"))
        self.assertFalse(served("/move_base/DWAPlannerROS"))
        cfg = tpr.get_configuration(timeout=10)
        self.assertAlmostEqual(cfg["max_vel_x"], 0.65)   # base_local_planner_params.yaml's, not the .cfg's 0.55

        # 1. the running planner
        client.send_goal(mb.make_goal(6.0, 0.0, 0.0))
        waits.wait_for(lambda: speed.now() > FAST, f"a ground-truth speed above {FAST} m/s")
        fast = speed.now()
        cfg = tpr.update_configuration({"max_vel_x": SLOW})
        self.assertAlmostEqual(cfg["max_vel_x"], SLOW)
        t_change = rospy.Time.now().to_sec()
        state, text = mb.wait_result(client, 120.0)
        self.assertEqual(state, "SUCCEEDED", text)
        after = speed.speeds(t_change + SETTLE)
        print(f"RECONFIGURE_TPR speed_before={fast:.3f} top_after_change={after.max():.3f} "
              f"(n={len(after)})", flush=True)
        self.assertLessEqual(after.max(), SLOW + SPEED_MARGIN)

        # 2. the next goal's planner
        t0 = rospy.Time.now().to_sec()
        client.send_goal(mb.make_goal(2.0, 0.0, math.pi))
        state, text = mb.wait_result(client, 120.0)
        self.assertEqual(state, "SUCCEEDED", text)
        leg = speed.speeds(t0)
        print(f"RECONFIGURE_TPR next_goal_top_speed={leg.max():.3f}", flush=True)
        self.assertLessEqual(leg.max(), SLOW + SPEED_MARGIN)
        self.assertGreater(leg.max(), 0.2)

        # 3. refused values, restore_defaults
        cfg = tpr.update_configuration({"max_vel_x": 50.0})
        self.assertAlmostEqual(cfg["max_vel_x"], SLOW, msg="an out-of-range value must be refused")
        cfg = tpr.update_configuration({"sim_time": 0.0})
        self.assertAlmostEqual(cfg["sim_time"], 1.0, msg="sim_time 0 must be refused")
        cfg = tpr.update_configuration({"restore_defaults": True})
        self.assertAlmostEqual(cfg["max_vel_x"], 0.65)
        self.assertFalse(cfg["restore_defaults"])

        # 4. GlobalPlanner: lethal_cost decides whether an inflated cell can be a goal
        g = waits.Latest("/move_base/global_costmap/costmap", OccupancyGrid).wait()
        occ = np.asarray(g.data, dtype=np.int16).reshape(g.info.height, g.info.width)
        res, ox, oy = g.info.resolution, g.info.origin.position.x, g.info.origin.position.y
        rows, cols = np.nonzero((occ >= 40) & (occ <= 90))   # costmap cost ~100..230
        xs, ys = ox + (cols + 0.5) * res, oy + (rows + 0.5) * res
        pose = truth.pose
        # the nearest one more than 1 m away: ~make_plan plans as if the square of the
        # circumscribed radius around the robot were free (make_plan_clear_costmap)
        d = np.hypot(xs - pose[0], ys - pose[1])
        k = int(np.argmin(np.where(d > 1.0, d, np.inf)))
        goal = (float(xs[k]), float(ys[k]))
        rospy.wait_for_service("/move_base/make_plan", 30.0)
        make_plan = rospy.ServiceProxy("/move_base/make_plan", GetPlan)

        def plan_to(x, y):
            r = GetPlanRequest()
            r.goal = PoseStamped()
            r.goal.header.frame_id = "map"
            r.goal.pose.position.x, r.goal.pose.position.y = x, y
            r.goal.pose.orientation.w = 1.0
            return make_plan(r).plan.poses

        self.assertGreater(len(plan_to(*goal)), 0, f"a plan to the inflated cell {goal}")
        self.assertEqual(gp.update_configuration({"lethal_cost": 60})["lethal_cost"], 60)
        self.assertEqual(len(plan_to(*goal)), 0, f"no plan to {goal} once its cost counts as lethal")
        self.assertEqual(gp.update_configuration({"lethal_cost": 253})["lethal_cost"], 253)
        self.assertGreater(len(plan_to(*goal)), 0)
        cfg = gp.update_configuration({"cost_factor": 9.0})
        self.assertAlmostEqual(cfg["cost_factor"], 3.0, msg="an out-of-range cost_factor must be refused")
        print(f"RECONFIGURE_TPR inflated_goal=({goal[0]:.2f}, {goal[1]:.2f}) occupancy={occ[rows[k], cols[k]]}",
              flush=True)
        self.assertEqual(truth.collisions, 0)


if __name__ == "__main__":
    rostest.rosrun("my_summit_path_planning", "move_base_reconfigure_tpr", ReconfigureTPR, sys.argv)
