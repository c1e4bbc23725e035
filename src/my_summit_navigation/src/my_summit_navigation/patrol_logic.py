"""Patrol: cruising a list of spots with retries, skips and stuck detection (no ROS here).

The patrol node (scripts/patrol.py) sends one move_base goal at a time through an
actionlib client and asks this module what to do with each outcome:

- ``build_stops``: the patrol list, from labels of a spots file (a SpotBook) or from
  poses [x, y, yaw_deg]; an entry that cannot be a goal (unknown label, bad pose) is kept
  with the reason, reported and skipped every round;
- ``decide``: after a goal ends: SUCCEEDED -> next spot; ABORTED (or stuck) -> clear the
  costmaps and retry while retries are left, then skip the spot and say why;
- ``ProgressWatch``: "stuck" when the distance to the goal (from move_base's feedback)
  has not shrunk by min_progress for stuck_timeout seconds;
- ``PatrolLog``: one line per goal and the summary (reached, retried, skipped, time).

In the manner of the waypoint patrol examples of the ROS navigation tutorials (a
SimpleActionClient with done/active/feedback callbacks), with the recovery a user adds
on top: clear costmaps and retry, then skip.
"""
import math
from dataclasses import dataclass, field

from my_summit_localization.spots import Spot

NEXT, RETRY, SKIP = "next", "retry", "skip"
SUCCEEDED, ABORTED, PREEMPTED, REJECTED = 3, 4, 2, 5   # actionlib_msgs/GoalStatus


@dataclass
class Stop:
    """One patrol entry: a name, its goal (a Spot in frame) or why it cannot be one."""

    name: str
    spot: Spot = None
    frame: str = "map"
    error: str = None


def build_stops(labels=None, book=None, poses=None, frame="map"):
    """The patrol list: labels looked up in book (a spot_goals.SpotBook), or poses
    ([x, y, yaw_deg] or {x, y, yaw_deg[, name]}). Bad entries keep their reason."""
    stops = []
    if labels is not None:
        book.refresh()
        for label in labels:
            spot, spot_frame, refusal = book.lookup(str(label))
            stops.append(Stop(str(label), spot, spot_frame or frame, refusal))
        return stops
    for i, entry in enumerate(poses or []):
        name = f"pose {i + 1}"
        try:
            if isinstance(entry, dict):
                name = str(entry.get("name", name))
                x, y, yaw_deg = (float(entry[k]) for k in ("x", "y", "yaw_deg"))
            else:
                x, y, yaw_deg = (float(v) for v in entry)
            if not all(math.isfinite(v) for v in (x, y, yaw_deg)):
                raise ValueError("not finite")
            stops.append(Stop(name, Spot.from_xy_yaw(x, y, math.radians(yaw_deg)), frame))
        except (KeyError, TypeError, ValueError) as e:
            stops.append(Stop(name, None, frame, f"bad pose {entry!r}: expected [x, y, yaw_deg] ({e})"))
    return stops


def decide(state, text, attempt, max_retries, stuck=False):
    """(action, reason) after a goal ended: NEXT, RETRY (clear costmaps first) or SKIP.

    attempt: 1 for the first try of this spot; max_retries: how many more tries an
    aborted or stuck goal gets."""
    if state == SUCCEEDED and not stuck:
        return NEXT, "reached"
    why = "stuck: no progress" if stuck else \
        f"move_base {'aborted' if state == ABORTED else 'ended the goal (state %d)' % state}: " \
        f"{(text or '').strip() or 'no reason given'}"
    if attempt <= max_retries:
        return RETRY, why
    return SKIP, f"{why} (after {attempt} tries)"


class ProgressWatch:
    """Stuck detection from feedback: no min_progress [m] closer to the goal within
    stuck_timeout [s] (ROS time) means stuck. Call reset() for each new goal."""

    def __init__(self, stuck_timeout, min_progress=0.1):
        self.stuck_timeout = float(stuck_timeout)
        self.min_progress = float(min_progress)
        self.reset(0.0)

    def reset(self, now):
        self.best = math.inf
        self.since = now

    def update(self, distance, now):
        """Feed the robot's distance to the goal at time now; True once stuck."""
        if distance < self.best - self.min_progress or self.best == math.inf:
            self.best, self.since = distance, now
            return False
        return self.stuck_timeout > 0 and now - self.since > self.stuck_timeout


@dataclass
class PatrolLog:
    """Counts and lines for the patrol's log and summary."""

    reached: int = 0
    retried: int = 0
    skipped: int = 0
    skipped_why: dict = field(default_factory=dict)   # name -> last reason

    def goal_line(self, round_no, stop, action, reason, took):
        if action == NEXT:
            self.reached += 1
        elif action == RETRY:
            self.retried += 1
        else:
            self.skipped += 1
            self.skipped_why[stop.name] = reason
        verb = {NEXT: "reached", RETRY: "retrying", SKIP: "SKIPPED"}[action]
        return f"patrol round {round_no}: '{stop.name}' {verb} after {took:.1f} s" + \
            ("" if action == NEXT else f": {reason}")

    def summary(self, rounds, elapsed):
        text = (f"patrol done: {rounds} round(s) in {elapsed:.1f} s; reached {self.reached}, "
                f"retried {self.retried}, skipped {self.skipped}")
        if self.skipped_why:
            text += "; skipped: " + "; ".join(f"'{k}' ({v})" for k, v in self.skipped_why.items())
        return text
