"""explore's goal bookkeeping without ROS: one planning round at a time.

Reference: explore_lite (J. Horner, m-explore, ROS wiki): every round at
planner_frequency, find the frontiers on the global costmap, send move_base the cheapest
one's goal, blacklist a goal move_base aborts or that sees no progress for
progress_timeout. The frontier search, the progress timer, the blacklist and the
stuck-robot watch are in frontiers.py; this module decides, round by round, what the
node does with them: keep the active goal, give it up (and cancel it), send a new one,
or end the exploration with the reason.

Explore is pure: time comes in as seconds [s], the costmap as an OccupancyGrid-valued
array, the robot's pose as (x, y, yaw); each step returns a Round saying what to send,
cancel, publish and log.
"""
import math
from dataclasses import dataclass, field

from . import frontiers as fr

# actionlib_msgs/GoalStatus values move_base's goals end with
SUCCEEDED, ABORTED = 3, 4
# [m] this near the goal, with its frontier in the laser's view (frontiers.in_view),
# counts as there: what can be seen from it has been seen. Beside a wall move_base may be
# unable to turn to the goal heading and never report the goal reached.
REACHED = 0.3
SAME_GOAL = 0.5      # [m] a frontier goal this close to the active one keeps it
EMPTY_ROUNDS = 4     # costmaps in a row without a frontier before it is over


@dataclass
class Round:
    """What one planning round asks of the node.

    send: the Frontier whose goal to send (heading goal_yaw [rad]), or None; cancel: cancel
    the active move_base goal (given up); clear_costmaps: ask move_base to clear its
    costmaps; frontiers: the frontiers found, cheapest first (None: not searched this
    round); over: why exploration is over, or None; logs: [(level 'info' / 'warn', text)].
    """

    send: object = None
    goal_yaw: float = 0.0
    cancel: bool = False
    clear_costmaps: bool = False
    frontiers: list = None
    over: str = None
    logs: list = field(default_factory=list)


class Explore:
    """explore's state across rounds: the active goal, the blacklist, the progress and
    stuck watches, the counts.

    params: frontiers.FrontierParams; progress_timeout [s]; stall_hold [s] (a goal
    without progress that long is kept until it ends; 0: never); stuck_goals,
    stuck_distance [m] (frontiers.StuckWatch).
    """

    def __init__(self, params=fr.FrontierParams(), progress_timeout=30.0, stall_hold=5.0, stuck_goals=6,
                 stuck_distance=0.5):
        self.params = params
        self.progress_timeout = float(progress_timeout)
        self.stall_hold = float(stall_hold)
        self.stuck = fr.StuckWatch(stuck_goals, stuck_distance)
        self.blacklist = fr.Blacklist(params.blacklist_radius)
        # no progress for progress_timeout towards a goal, kept across goal switches
        self.progress = fr.GoalProgress(self.progress_timeout, same=SAME_GOAL)
        self.goal = None            # (x, y) of the active goal
        self.goal_centroid = None   # (x, y) of its frontier's centroid
        self.goal_state = None      # how move_base ended it (GoalStatus value), None while active
        self.sent = 0
        self.failed = 0             # goals aborted or without progress
        self.empty_rounds = 0       # costmaps in a row on which no frontier was found
        self.empty_stamp = None     # the stamp of the last of them
        self.cleared = False        # the costmaps were cleared for frontiers out of reach since the last goal

    def goal_done(self, number, state):
        """move_base ended goal number (1 for the first goal sent, as in the logs) with
        GoalStatus state. The end of an earlier goal is ignored: it can arrive after the
        round that counted that goal as reached has sent the next one."""
        if number == self.sent:
            self.goal_state = state

    def _give_up(self, out, why, robot, no_progress=False):
        """Blacklist the active goal and cancel it; the reason exploration is over when the
        robot, not the goal, is the problem (StuckWatch: only goals given up for no
        progress count, move_base aborts a goal in an obstacle at once), else None."""
        out.logs.append(("warn", f"blacklisting ({self.goal[0]:.2f}, {self.goal[1]:.2f}): {why} "
                                 f"(robot at ({robot[0]:.2f}, {robot[1]:.2f}))"))
        self.blacklist.add(self.goal, no_progress=no_progress)
        self.failed += 1
        out.cancel = True
        self.goal = None
        if no_progress and self.stuck.given_up(robot):
            return (f"the robot is stuck at ({robot[0]:.2f}, {robot[1]:.2f}): {self.stuck.goals} goals in a row "
                    f"given up without it moving {self.stuck.distance:.1f} m")
        return None

    def _check_goal(self, out, pose, now):
        """The active goal: ended, reached, or no progress? Returns the reason it is over."""
        robot = pose[:2]
        if self.goal_state == ABORTED:
            return self._give_up(out, "move_base aborted it", robot)
        d = math.hypot(robot[0] - self.goal[0], robot[1] - self.goal[1])
        if self.goal_state is not None or (d <= REACHED and fr.in_view(pose, self.goal_centroid)):
            # reached (or ended otherwise): what can be seen from there has been seen; a
            # frontier whose goal falls here again is a pocket the laser cannot fill
            self.blacklist.add(self.goal)
            self.goal = None
            return None
        if self.progress.update(d, now):
            return self._give_up(out, f"no progress for {self.progress_timeout:.0f} s", robot, no_progress=True)
        return None

    def _nothing_found(self, out, grid, resolution, origin, robot, stamp):
        if self.goal is not None and self.goal_state is None:
            return None   # let the last goal finish: it may uncover more
        # Over only when it stays so on EMPTY_ROUNDS costmaps: the costmap follows a map
        # published every few seconds, and the robot may stand in a cell the latest update
        # marked (then nothing is reachable from it for a moment). A round that runs again
        # on a costmap already counted (rounds late under load run back to back) adds nothing.
        if stamp is not None and stamp == self.empty_stamp:
            return None
        self.empty_stamp = stamp
        self.empty_rounds += 1
        if self.empty_rounds < EMPTY_ROUNDS:
            out.logs.append(("info", f"no frontier found ({self.empty_rounds}/{EMPTY_ROUNDS}); looking again"))
            return None
        again = self.blacklist.second_chance()
        if again:
            # goals given up for no progress may have met a stall, not a closed way
            for g in again:
                self.progress.forget(g)
            self.empty_rounds = 0
            out.logs.append(("warn", f"no frontier left but {len(again)} given up for no progress: one more "
                                     "try at " + ", ".join(f"({x:.2f}, {y:.2f})" for x, y in again)))
            return None
        beyond = fr.frontiers_out_of_reach(grid, resolution, origin, robot, self.params)
        if beyond and not self.cleared:
            # The way to them may be closed by obstacle marks the costmap keeps where the
            # laser no longer looks: hits placed while the map -> odom correction lagged a
            # turn narrowed a 1 m door below the robot's width. Cleared, the costmap is the
            # map again; ending is for a way the map itself closes.
            self.cleared = True
            self.empty_rounds = 0
            out.clear_costmaps = True
            out.logs.append(("warn", f"{beyond} frontier{'s' if beyond > 1 else ''} seen where the robot cannot "
                                     "pass: clearing move_base's costmaps and looking again"))
            return None
        if self.failed == 0 and beyond == 0:
            return "no frontiers left"
        why = [f"{self.failed} goals failed and blacklisted"] if self.failed else []
        if beyond:
            why.append(f"{beyond} frontier{'s' if beyond > 1 else ''} seen where the robot cannot pass")
        return f"no reachable frontier left ({'; '.join(why)})"

    def step(self, now, pose, grid, resolution, origin, stamp=None):
        """One planning round at now [s]: pose (x, y, yaw) of the robot in the grid's frame;
        grid (H, W) OccupancyGrid values of the global costmap, resolution [m/cell],
        origin (x, y) [m], stamp: the costmap's header stamp [s] (None: a new costmap each
        round). Returns a Round."""
        out = Round()
        robot = tuple(pose[:2])
        self.stuck.update(robot)
        if self.goal is not None:
            out.over = self._check_goal(out, pose, now)
            if out.over is not None:
                return out
        found = fr.find_frontiers(grid, resolution, origin, robot, self.params, self.blacklist)
        out.frontiers = found
        if not found:
            out.over = self._nothing_found(out, grid, resolution, origin, robot, stamp)
            return out
        self.empty_rounds, self.empty_stamp = 0, None
        if self.goal is not None and any(math.hypot(f.goal[0] - self.goal[0], f.goal[1] - self.goal[1]) < SAME_GOAL
                                         for f in found[:3]):
            return out
        if self.goal is not None and 0 < self.stall_hold <= self.progress.stalled(now):
            # A goal without progress for stall_hold is kept until it is reached, aborted or
            # given up: each new goal restarts move_base's recoveries, which then never get
            # to the one that would free the robot.
            return out
        self._send(out, found[0], pose, now)
        return out

    def _send(self, out, frontier, pose, now):
        # arrive heading the way the robot drives there, or facing the frontier when it
        # would be behind
        out.send = frontier
        out.goal_yaw = fr.goal_heading(pose[:2], frontier.goal, frontier.centroid)
        self.goal, self.goal_state, self.goal_centroid = tuple(frontier.goal), None, frontier.centroid
        self.cleared = False
        again = self.progress.start(self.goal, now)
        self.sent += 1
        out.logs.append(("info", f"goal {self.sent}: frontier of {frontier.size:.1f} m at ({self.goal[0]:.2f}, "
                                 f"{self.goal[1]:.2f}), {frontier.distance:.1f} m away"
                                 + (" (again: its progress timer runs on)" if again else "")))
