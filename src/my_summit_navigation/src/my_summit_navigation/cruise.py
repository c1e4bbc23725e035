"""Cruise: laps over waypoints through move_base, with retries, skips, stall detection
and a charging dock (no ROS here).

The decision core of the two cruise nodes, auto_navigator (waypoints from a YAML file,
laps, battery and dock: the race-track tutorial's node) and patrol.py (spots of the
course building by label or pose, rounds, return home). Both are one ROS adapter
(``my_summit_navigation.cruise_node``) around ``Cruise``, a state machine fed events
with their time stamps and answering with commands:

- events: ``start``, ``goal_done`` (move_base's terminal state and text), ``feedback``
  (the robot's position from move_base's feedback), ``battery`` (BatteryState's
  percentage, 0..1, and power_supply_status; ``battery_problem`` tells which messages
  to drop), ``tick`` (time passing), ``return_home``;
- commands: ``Send`` a goal, ``Cancel`` it, ``ClearCostmaps``, ``Log`` a line,
  ``Finish`` with the summary (a dict; JSON for auto_navigator's ~summary).

The rules: SUCCEEDED -> next waypoint; ABORTED / REJECTED, or no progress for
movement_timeout [s] (cancel first) -> clear the costmaps and retry while max_retries are
left, then skip the waypoint with the reason. Battery below low_battery -> cancel, drive
to the dock, wait there until resume_battery (or the status FULL), resume at the
interrupted waypoint (same lap, same index; not a skip). Below critical_battery away
from the dock, or at the dock while not charging -> cancel and stop ("critical"). A dock
goal that fails after its retries -> stop ("dock_unreachable").

Reaching the dock goal does not mean charging: move_base's tolerance plus the
localization error can leave the robot beside the charger's contacts. At the dock the
cruise checks the charger every charge_start_timeout [s] from the arrival, on the
battery messages: it works when the last status is CHARGING or FULL and the level has
not fallen since the check before, or, for a driver that reports no status (UNKNOWN),
when the level has risen. When it does not, the dock goal is sent again (a retry, as
for an aborted goal); after max_retries the cruise stops ("dock_unreachable", the
charger did not engage). Between the checks the charger counts as working by the same
rule with "not fallen" for UNKNOWN, and the critical stop applies when it does not; in
the first charge_start_timeout after an arrival it counts as working (the charger and
the status may take a message or two to switch on).
No battery message within battery_timeout [s] -> one warning, cruise without battery
handling until one comes.

It follows the tutorial's auto_nav node (seeds/003: a waypoint queue sent with
SimpleActionClient done / active / feedback callbacks; clear_costmaps on ABORTED; cancel
and recover after 30 s without movement; to the charging station below 20 % battery)
and the waypoint patrol of the ROS navigation tutorials.

Also here: ``build_stops`` (the patrol list from spot labels or poses),
``load_waypoints`` (auto_navigator's YAML), ``decide``, ``battery_problem``,
``ProgressWatch``, ``PatrolLog``.
"""
import math
from dataclasses import dataclass, field

from my_summit_localization.spots import Spot
from summit_nav_common.diagnostic_checks import ERROR, OK, WARN, Check
from summit_nav_common.route import RouteError, parse_pose, read_route

NEXT, RETRY, SKIP = "next", "retry", "skip"
SUCCEEDED, ABORTED, PREEMPTED, REJECTED = 3, 4, 2, 5   # actionlib_msgs/GoalStatus
# sensor_msgs/BatteryState power_supply_status
POWER_UNKNOWN, POWER_CHARGING, POWER_DISCHARGING, POWER_NOT_CHARGING, POWER_FULL = 0, 1, 2, 3, 4
POWER_STATUS_NAMES = {POWER_UNKNOWN: "unknown", POWER_CHARGING: "charging", POWER_DISCHARGING: "discharging",
                      POWER_NOT_CHARGING: "not charging", POWER_FULL: "full"}

# End states of a run (the summary's "state")
COMPLETED, CRITICAL, DOCK_UNREACHABLE, STOPPED = "completed", "critical", "dock_unreachable", "stopped"

CANCEL_WAIT = 5.0      # [s] for move_base to end a canceled goal before the cruise goes on without it
RETRY_PAUSE = 1.0      # [s] after clearing the costmaps, before the retry (fresh sensor data)
DOCK_RADIUS = 0.3      # [m] the robot this near the dock is at the dock (the simulator's charger radius)


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
        name = str(entry.get("name", f"pose {i + 1}")) if isinstance(entry, dict) else f"pose {i + 1}"
        try:
            stops.append(Stop(name, _spot(parse_pose(entry)), frame))
        except ValueError as e:
            stops.append(Stop(name, None, frame, f"bad pose: {e}"))
    return stops


def _pct(fraction):
    """A battery fraction (0..1) as a percentage with one decimal, e.g. "19.6 %": whole
    percents would print a level just under a threshold as equal to it."""
    return f"{100.0 * fraction:.1f} %"


def _spot(pose):
    """The Spot of a route pose (x [m], y [m], yaw_deg [deg])."""
    x, y, yaw_deg = pose
    return Spot.from_xy_yaw(x, y, math.radians(yaw_deg))


class WaypointFileError(ValueError):
    """A waypoint file that cannot be used; the text names the file and the entry."""


def load_waypoints(path, frame="map"):
    """(stops, dock) from a waypoint file (the route file of summit_nav_common.route):

        waypoints: [{name: s1, x: 1.0, y: 2.0, yaw_deg: 90}, ...]   # [m], [m], [deg]
        dock: {x: 0.0, y: 0.0, yaw_deg: 0}                          # optional

    Other keys (such as ``start:``) are ignored; a waypoint without a name is called
    ``waypoints[i]``. A bad waypoint entry becomes a Stop with
    its reason (reported and skipped every lap); a missing or unparsable file, no
    ``waypoints`` list, no usable waypoint at all or a bad ``dock`` raise
    WaypointFileError naming the file and the entry. dock is a Stop named "dock" or None.
    """
    try:
        route = read_route(path)
        dock = route.dock.checked() if route.dock is not None else None
    except RouteError as e:
        raise WaypointFileError(f"waypoint file {e}") from None
    stops = []
    for i, wp in enumerate(route.waypoints):
        if wp.name is None:
            name, label = f"waypoints[{i}]", wp.where
        else:
            name = str(wp.name)
            label = f"{wp.where} ('{name}')"
        if wp.error is None:
            stops.append(Stop(name, _spot(wp.pose), frame))
        else:
            stops.append(Stop(name, None, frame, f"{label}: {wp.error}"))
    if all(s.error for s in stops):
        raise WaypointFileError(f"waypoint file {path}: no usable waypoint: " + "; ".join(s.error for s in stops))
    return stops, (None if dock is None else Stop("dock", _spot(dock), frame))


def parse_dock(entry, frame, where):
    """The dock Stop from {x, y, yaw_deg} or [x, y, yaw_deg]; WaypointFileError naming
    where when it cannot be a goal."""
    try:
        return Stop("dock", _spot(parse_pose(entry)), frame)
    except ValueError as e:
        raise WaypointFileError(f"{where}: {e}") from None


def decide(state, text, attempt, max_retries, stuck=False):
    """(action, reason) after a goal ended: NEXT, RETRY (clear costmaps first) or SKIP.

    attempt: 1 for the first try of this spot; max_retries: how many more tries an
    aborted or stuck goal gets; stuck: the cruise canceled the goal for lack of progress.
    SUCCEEDED is reached whatever a cancel on its way was for."""
    if state == SUCCEEDED:
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
        return self.stalled(now)

    def stalled(self, now):
        """True when the last progress (or the reset) is more than stuck_timeout ago:
        a goal that gets no feedback at all is as stuck as one that does not move."""
        return self.stuck_timeout > 0 and now - self.since > self.stuck_timeout


@dataclass
class PatrolLog:
    """Counts and lines for the cruise's log and summary; prefix names a round."""

    reached: int = 0
    retried: int = 0
    skipped: int = 0
    skipped_why: dict = field(default_factory=dict)   # name -> last reason
    skips: list = field(default_factory=list)         # {waypoint, lap, reason}, in order
    prefix: str = "patrol round"

    def goal_line(self, round_no, stop, action, reason, took):
        """Count the outcome of one goal; the log line (took [s])."""
        if action == NEXT:
            self.reached += 1
        elif action == RETRY:
            self.retried += 1
        else:
            self.skipped += 1
            self.skipped_why[stop.name] = reason
            self.skips.append({"waypoint": stop.name, "lap": round_no, "reason": reason})
        verb = {NEXT: "reached", RETRY: "retrying", SKIP: "SKIPPED"}[action]
        return f"{self.prefix} {round_no}: '{stop.name}' {verb} after {took:.1f} s" + \
            ("" if action == NEXT else f": {reason}")

    def summary(self, rounds, elapsed):
        """patrol's summary line: rounds started, elapsed [s], counts, skip reasons."""
        text = (f"patrol done: {rounds} round(s) in {elapsed:.1f} s; reached {self.reached}, "
                f"retried {self.retried}, skipped {self.skipped}")
        if self.skipped_why:
            text += "; skipped: " + "; ".join(f"'{k}' ({v})" for k, v in self.skipped_why.items())
        return text


# -- commands to the ROS adapter ------------------------------------------------------------
@dataclass
class Send:
    """Send stop's goal to move_base; goal_id comes back with its events."""
    goal_id: int
    stop: Stop


@dataclass
class Cancel:
    """Cancel the current goal."""


@dataclass
class ClearCostmaps:
    """Call move_base's ~clear_costmaps."""


@dataclass
class Log:
    """A log line; level is OK (info), WARN or ERROR."""
    level: int
    text: str


@dataclass
class Finish:
    """The run is over: publish summary (a dict)."""
    summary: dict


@dataclass
class BatteryLimits:
    """The battery thresholds, as fractions of a full charge (BatteryState.percentage)."""

    low: float = 0.2         # below: go to the dock
    resume: float = 0.9      # at the dock, at or above: cruise on
    critical: float = 0.05   # below, away from the dock or at it without charging: stop
    timeout: float = 5.0     # [s] without any battery message: cruise without battery handling
    charge_start_timeout: float = 10.0  # [s] at the dock, between checks that the charger works

    def check(self):
        """ValueError unless 0 <= critical < low < resume <= 1 and both timeouts > 0."""
        if not (0.0 <= self.critical < self.low < self.resume <= 1.0):
            raise ValueError(f"battery thresholds: need 0 <= critical_battery ({self.critical}) < low_battery "
                             f"({self.low}) < resume_battery ({self.resume}) <= 1")
        if not self.timeout > 0:
            raise ValueError(f"battery_timeout must be > 0 s, got {self.timeout}")
        if not self.charge_start_timeout > 0:
            raise ValueError(f"charge_start_timeout must be > 0 s, got {self.charge_start_timeout}")
        return self


@dataclass
class _Goal:
    goal_id: int
    kind: str            # "waypoint", "dock" or "home"
    stop: Stop
    sent_at: float       # [s]


# Activities (the diagnostics' "state" while running)
CRUISING, RETRYING, RECOVERING, TO_DOCK, CHARGING, HOMING, DONE = (
    "cruising", "retrying", "recovering", "going to charge", "charging", "returning home", "done")


def battery_problem(percentage, present=True):
    """Why a BatteryState cannot be used (one text per kind of problem), or None: the
    battery absent (present False), the level unknown (NaN, as BatteryState allows) or
    outside 0..1 (e.g. a driver that publishes 0-100)."""
    if not present:
        return "present is false (no battery)"
    if not math.isfinite(percentage):
        return "percentage NaN (level unknown)"
    if not 0.0 <= percentage <= 1.0:
        return "percentage outside 0..1 (a 0-100 scale?)"
    return None


class Cruise:
    """The cruise's state machine (see the module docstring). Times are in seconds of one
    clock (ROS time in the node, a fake one in tests); every event returns the list of
    commands to carry out, in order.

    stops: the waypoints (Stop; one with an error is skipped every lap); laps: how many
    (0 = forever); dock: a Stop or None (then low battery only warns); home: a Stop for
    return_home, or None; prefix: names a lap in the log lines ("lap", "patrol round").
    """

    def __init__(self, stops, laps=1, max_retries=2, movement_timeout=30.0, dock=None, home=None,
                 battery=None, prefix="lap", min_progress=0.1, retry_pause=RETRY_PAUSE):
        if laps < 0:
            raise ValueError(f"laps must be >= 0 (0 = forever), got {laps}")
        if max_retries < 0:
            raise ValueError(f"max_retries must be >= 0, got {max_retries}")
        self.stops = list(stops)
        self.laps = int(laps)
        self.max_retries = int(max_retries)
        self.dock = dock
        self.home = home
        self.battery_limits = (battery or BatteryLimits()).check()
        self.retry_pause = float(retry_pause)
        self.watch = ProgressWatch(movement_timeout, min_progress)
        self.log = PatrolLog(prefix=prefix)
        self.activity = None            # None before start, then one of the activities above
        self.end_state = None           # COMPLETED / CRITICAL / DOCK_UNREACHABLE / STOPPED
        self.end_reason = ""
        self.lap = 0                    # current lap, 1-based; 0 before start
        self.index = 0                  # current waypoint in stops
        self.attempt = 0                # tries of the current target (waypoint or dock)
        self.laps_done = 0
        self.lap_times = []             # [s]
        self.dock_visits = 0
        self.low_battery_events = 0
        self.percentage = None          # last BatteryState.percentage, None before any
        self.power_status = POWER_UNKNOWN   # last BatteryState.power_supply_status
        self.charge_retries = 0         # dock goals re-sent this visit because the charger did not engage
        self._charge_check = None       # at the dock: (since [s], level then, first window after arrival)
        self.battery_missing = False    # warned that none came within the timeout
        self.no_dock_warned = False
        self.position = None            # (x, y) [m] from the last feedback
        self._goal = None               # the goal move_base has, or None
        self._cancel = None             # (why, since [s]) while a cancel is awaited
        self._retry_at = None           # [s] when the pending retry is sent
        self._next_id = 0
        self._t0 = self._lap_t0 = self._t_end = None

    # -- queries --------------------------------------------------------------------------
    @property
    def done(self):
        return self.end_state is not None

    def current_stop(self):
        """The waypoint being (or next to be) driven to; None past the lap's end."""
        i = self.index
        return self.stops[i] if 0 <= i < len(self.stops) else None

    def battery_action(self):
        """What the battery makes the cruise do, for the diagnostics."""
        if self.activity == TO_DOCK:
            return "going to the dock"
        if self.activity == CHARGING:
            return "charging" if self._charger_works(rising=False) else "waiting for the charger"
        if self.percentage is None:
            return "no battery data" if self.battery_missing else "waiting for battery data"
        if self.percentage < self.battery_limits.low and self.dock is None:
            return "low, no dock"
        return "none"

    def status(self):
        """The diagnostics' Check (level, message, values): OK cruising or done, WARN
        while retrying, recovering, going to charge or charging, ERROR on critical or
        dock_unreachable."""
        if self.end_state in (CRITICAL, DOCK_UNREACHABLE):
            level, message = ERROR, f"{self.end_state}: {self.end_reason}"
        elif self.done:
            level, message = OK, f"done ({self.end_state}): {self.laps_done} lap(s)"
        elif self.activity in (RETRYING, RECOVERING, TO_DOCK, CHARGING):
            level, message = WARN, self.activity
        elif self.activity is None:
            level, message = OK, "waiting to start"
        else:
            level, message = OK, self.activity
        stop = self.current_stop()
        values = {"state": self.end_state or self.activity or "starting",
                  "lap": f"{self.lap}" + (f" of {self.laps}" if self.laps else " (forever)"),
                  "waypoint": stop.name if stop is not None and not self.done else "",
                  "battery action": self.battery_action(),
                  "battery percentage": "" if self.percentage is None else f"{100.0 * self.percentage:.1f}",
                  "dock visits": str(self.dock_visits),
                  "reached": str(self.log.reached),
                  "skipped": str(self.log.skipped)}
        return Check(level, message, tuple(values.items()))

    def summary(self, now):
        """The run's summary (JSON-ready dict); time_s counts to the end, or to now."""
        end = self._t_end if self._t_end is not None else now
        return {"state": self.end_state or "running",
                "reason": self.end_reason,
                "laps": self.laps_done,
                "laps_requested": self.laps,
                "reached": self.log.reached,
                "skipped": list(self.log.skips),
                "retries": self.log.retried,
                "dock_visits": self.dock_visits,
                "low_battery_events": self.low_battery_events,
                "lap_times_s": [round(t, 1) for t in self.lap_times],
                "time_s": round(end - self._t0, 1) if self._t0 is not None else 0.0}

    def at_dock(self):
        """Charging (the charger works, or may still engage: the first charge_start_timeout
        after the arrival), or, on the way, within DOCK_RADIUS of the dock by the last
        feedback. Parked at the dock with the charger off is not at the dock: the
        critical stop applies there."""
        if self.activity == CHARGING:
            return self._charge_check[2] or self._charger_works(rising=False)
        return self.dock is not None and self.position is not None and \
            math.hypot(self.position[0] - self.dock.spot.x, self.position[1] - self.dock.spot.y) <= DOCK_RADIUS

    # -- events ---------------------------------------------------------------------------
    def start(self, now):
        """Begin lap 1 at time now [s]."""
        self._t0 = self._lap_t0 = now
        self.lap, self.index, self.attempt = 1, 0, 0
        self.activity = CRUISING
        out = [Log(WARN, f"'{s.name}' will be skipped every {self.log.prefix}: {s.error}")
               for s in self.stops if s.error]
        return out + self._advance(now)

    def goal_done(self, goal_id, state, text, now):
        """move_base ended goal goal_id in state (GoalStatus) with text."""
        if self._goal is None or goal_id != self._goal.goal_id or self.done:
            return []       # an old goal's late answer
        goal, self._goal = self._goal, None
        why = self._cancel[0] if self._cancel else None
        self._cancel = None
        took = now - goal.sent_at
        out = []
        if why in ("home", "battery") and goal.kind == "waypoint" and state == SUCCEEDED:
            # it got there while the cancel was on its way: the stop counts as reached
            out.append(Log(OK, self.log.goal_line(self.lap, goal.stop, NEXT, "reached", took)))
            self._next_waypoint()
        if why == "home":
            return out + self._send(self.home, "home", now)
        if goal.kind == "home":
            return [Log(OK, f"return home: {'reached' if state == SUCCEEDED else 'not reached'} after "
                            f"{took:.1f} s ({(text or '').strip() or 'state %d' % state})")] + \
                self._finish(STOPPED, "return home requested", now)
        if goal.kind == "dock":
            return self._dock_done(state, text, why == "stuck", took, now)
        if why == "battery":
            if not out:
                out = [Log(WARN, f"{self.log.prefix} {self.lap}: '{goal.stop.name}' interrupted after {took:.1f} s: "
                                 f"battery low (resumed after charging)")]
            return out + self._go_dock(now)
        action, reason = decide(state, text, self.attempt, self.max_retries, stuck=why == "stuck")
        out = [Log(OK if action == NEXT else WARN, self.log.goal_line(self.lap, goal.stop, action, reason, took))]
        if action == RETRY:
            return out + self._recover(now)
        self._next_waypoint()
        return out + self._advance(now)

    def feedback(self, goal_id, x, y, now):
        """The robot at (x, y) [m] (move_base's feedback base_position) during goal_id."""
        self.position = (x, y)
        if self._goal is None or goal_id != self._goal.goal_id or self._cancel or self.done:
            return []
        dist = math.hypot(x - self._goal.stop.spot.x, y - self._goal.stop.spot.y)
        if self.watch.update(dist, now):
            return self._stuck(now)
        return []

    def battery(self, percentage, now, status=POWER_UNKNOWN):
        """A BatteryState's percentage (0..1) and power_supply_status (POWER_*; UNKNOWN
        for a driver that does not report it) at time now."""
        out = []
        if self.battery_missing and self.percentage is None:
            out.append(Log(OK, f"battery data arrived ({_pct(percentage)}): battery handling on"))
        self.percentage = float(percentage)
        self.power_status = int(status)
        if self.done or self.activity is None:
            return out
        lim = self.battery_limits
        if self.percentage < lim.critical and not self.at_dock():
            text = (f"battery critical: {_pct(self.percentage)} < {_pct(lim.critical)} away from "
                    f"the dock; stopping here")
            out.append(Log(ERROR, text))
            if self._goal is not None:
                out.append(Cancel())
                self._goal = self._cancel = None
            return out + self._finish(CRITICAL, text, now)
        if self.activity == CHARGING:
            if self.percentage >= lim.resume or self.power_status == POWER_FULL:
                return out + self._resume(now)
            return out + self._check_charger(now)
        if self.percentage < lim.low and self.activity in (CRUISING, RETRYING, RECOVERING):
            if self.dock is None:
                if not self.no_dock_warned:
                    self.no_dock_warned = True
                    out.append(Log(WARN, f"battery low ({_pct(self.percentage)} < {_pct(lim.low)}) "
                                         f"but no dock is set: cruising on"))
                return out
            self.low_battery_events += 1
            stop = self.current_stop()
            out.append(Log(WARN, f"battery low ({_pct(self.percentage)} < {_pct(lim.low)}): going to "
                                 f"the dock; will resume at {self.log.prefix} {self.lap}, "
                                 f"'{stop.name if stop else '?'}'"))
            self.activity = TO_DOCK
            self._retry_at = None
            if self._goal is not None:
                self._cancel = ("battery", now)
                return out + [Cancel()]
            return out + self._go_dock(now)
        return out

    def tick(self, now):
        """Time passes: the battery timeout, a due retry, an unanswered cancel, a goal
        with no feedback at all."""
        out = []
        if self.done or self.activity is None:
            return out
        if self.percentage is None and not self.battery_missing and now - self._t0 > self.battery_limits.timeout:
            self.battery_missing = True
            out.append(Log(WARN, f"no battery data within {self.battery_limits.timeout:.0f} s: cruising without "
                                 f"battery handling (it starts when battery data comes)"))
        if self._cancel is not None and now - self._cancel[1] > CANCEL_WAIT:
            out.append(Log(WARN, f"move_base did not end the canceled goal within {CANCEL_WAIT:.0f} s; going on"))
            out += self.goal_done(self._goal.goal_id, PREEMPTED, "canceled, no answer", now)
        elif self._retry_at is not None and now >= self._retry_at:
            self._retry_at = None
            if self.activity == TO_DOCK:
                out += self._send(self.dock, "dock", now)
            else:
                self.activity = RETRYING
                out += self._send(self.current_stop(), "waypoint", now)
        elif self._goal is not None and self._cancel is None and self.watch.stalled(now):
            out += self._stuck(now)
        return out

    def return_home(self, now):
        """Interrupt the cruise and drive home (patrol's ~return_home); False when there
        is no home or the run is over."""
        if self.home is None or self.done or self.activity is None:
            return False, []
        self.activity = HOMING
        self._retry_at = None
        if self._goal is not None and self._goal.kind != "home":
            self._cancel = ("home", now)
            return True, [Cancel()]
        return True, self._send(self.home, "home", now)

    # -- internals ------------------------------------------------------------------------
    def _send(self, stop, kind, now):
        self._next_id += 1
        if kind != "home":
            self.attempt += 1
        self._goal = _Goal(self._next_id, kind, stop, now)
        self.watch.reset(now)
        return [Send(self._next_id, stop)]

    def _stuck(self, now):
        self._cancel = ("stuck", now)
        return [Log(WARN, f"no progress toward '{self._goal.stop.name}' for {self.watch.stuck_timeout:.0f} s: "
                          f"cancelling to recover"), Cancel()]

    def _recover(self, now):
        """Clear the costmaps; the retry goes out retry_pause [s] later (tick)."""
        if self.activity != TO_DOCK:
            self.activity = RECOVERING
        self._retry_at = now + self.retry_pause
        return [ClearCostmaps()]

    def _next_waypoint(self):
        self.index += 1
        self.attempt = 0

    def _advance(self, now):
        """Send the current waypoint, skipping bad entries and closing laps on the way."""
        out = []
        bad_in_a_row = 0
        while True:
            if self.index >= len(self.stops):
                took = now - self._lap_t0
                self.lap_times.append(took)
                self.laps_done += 1
                out.append(Log(OK, f"{self.log.prefix} {self.lap} done in {took:.1f} s"
                                   + (f" ({self.laps_done} of {self.laps})" if self.laps else "")))
                if self.laps and self.laps_done >= self.laps:
                    return out + self._finish(COMPLETED, f"{self.laps_done} lap(s) done", now)
                self.lap += 1
                self.index, self.attempt, self._lap_t0 = 0, 0, now
            stop = self.stops[self.index]
            if stop.error is None:
                break
            out.append(Log(WARN, self.log.goal_line(self.lap, stop, SKIP, stop.error, 0.0)))
            self.index += 1
            bad_in_a_row += 1
            if bad_in_a_row >= len(self.stops):
                return out + self._finish(STOPPED, "no waypoint can be a goal", now)
        lim = self.battery_limits
        if self.dock is not None and self.percentage is not None and self.percentage < lim.low:
            self.low_battery_events += 1
            self.activity = TO_DOCK
            out.append(Log(WARN, f"battery low ({_pct(self.percentage)} < {_pct(lim.low)}): to the dock before "
                                 f"'{stop.name}'"))
            return out + self._go_dock(now)
        self.activity = CRUISING
        return out + self._send(stop, "waypoint", now)

    def _go_dock(self, now):
        self.activity = TO_DOCK
        self.attempt = 0
        return self._send(self.dock, "dock", now)

    def _dock_done(self, state, text, stuck, took, now):
        action, reason = decide(state, text, self.attempt, self.max_retries, stuck)
        if action == NEXT:
            if self.charge_retries == 0:     # a charger retry is the same visit
                self.dock_visits += 1
            self.activity = CHARGING
            self.attempt = 0
            self._charge_check = (now, self.percentage, True)
            out = [Log(OK, f"at the dock after {took:.1f} s (visit {self.dock_visits}); charging to "
                           f"{_pct(self.battery_limits.resume)}")]
            if self.percentage is None or self.percentage >= self.battery_limits.resume:
                out += self._resume(now)
            return out
        if action == RETRY:
            self.log.retried += 1
            return [Log(WARN, f"dock: retrying after {took:.1f} s: {reason}")] + self._recover(now)
        text = f"the dock cannot be reached: {reason}; stopping here"
        return [Log(ERROR, text)] + self._finish(DOCK_UNREACHABLE, text, now)

    def _resume(self, now):
        stop = self.current_stop()
        out = [Log(OK, f"charged ({'? %' if self.percentage is None else _pct(self.percentage)}): "
                       f"resuming at {self.log.prefix} {self.lap}, '{stop.name if stop else '(lap end)'}'")]
        self.activity = CRUISING
        self.attempt = 0
        self.charge_retries = 0
        return out + self._advance(now)

    def _charger_works(self, rising):
        """At the dock: the charger works by the last message (the module docstring's
        rule); rising: a driver without a status must show the level risen, not only
        not fallen."""
        level0 = self._charge_check[1]
        if self.percentage is None or level0 is None:
            return True             # no battery data: nothing to judge by
        if self.power_status == POWER_UNKNOWN:
            return self.percentage > level0 if rising else self.percentage >= level0
        return self.power_status in (POWER_CHARGING, POWER_FULL) and self.percentage >= level0

    def _check_charger(self, now):
        """Every charge_start_timeout at the dock: the charger works -> wait on; it does
        not -> re-send the dock goal, or stop after max_retries."""
        since, level0, _first = self._charge_check
        timeout = self.battery_limits.charge_start_timeout
        if now - since < timeout:
            return []
        if self._charger_works(rising=True):
            self._charge_check = (now, self.percentage, False)
            return []
        seen = (f"status {POWER_STATUS_NAMES.get(self.power_status, self.power_status)}, level "
                f"{_pct(level0)} -> {_pct(self.percentage)} in {now - since:.1f} s")
        if self.charge_retries >= self.max_retries:
            text = (f"the dock cannot be reached: the charger did not engage ({seen}) after "
                    f"{self.charge_retries + 1} arrival(s); stopping here")
            return [Log(ERROR, text)] + self._finish(DOCK_UNREACHABLE, text, now)
        self.charge_retries += 1
        self.log.retried += 1
        out = [Log(WARN, f"dock: the charger did not engage ({seen}): sending the dock goal again "
                         f"(retry {self.charge_retries} of {self.max_retries})")]
        return out + self._go_dock(now)

    def _finish(self, state, reason, now):
        self.end_state, self.end_reason = state, reason
        self.activity = DONE
        self._t_end = now
        self._goal = self._cancel = self._retry_at = None
        return [Finish(self.summary(now))]
