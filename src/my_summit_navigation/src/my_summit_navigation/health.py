"""The navigation health report: the tutorial's key indicators measured on a running robot.

Follows the race-track tutorial's section 7.1 (key metrics and their ideal values:
localization error against the true pose < 0.1 m, path planning time < 1.0 s, control
rate >= 10 Hz, CPU < 70 %) and 4.3 (what rqt_runtime_monitor, ``rostopic hz`` and htop
show), as one report instead of four tools. The ROS adapter (scripts/nav_health) records
topics into a Recording; everything here is arrays in, numbers and pictures out:

- ``interpolate_track``: the simulator's truth (x, y, yaw) at amcl's pose stamps, linear
  between the two truth samples around each stamp (yaw on the shorter arc); a stamp with
  no truth within ``max_gap`` on both sides has none (NaN), so a pause of the truth is
  never bridged;
- ``stats``: median, 95th percentile and worst of a sample;
- ``PlanSampler``: planning times from move_base's "Global planner" statuses: a sample
  of "last plan time [s]" each time the count of attempts ("plans" + "failed attempts")
  changes, and the worst from "max plan time [s]" when it rises during the report, so a
  plan between two statuses still counts for the worst;
- ``window_rates``: messages per second in consecutive 1 s windows of simulated time that
  lie wholly inside the intervals where a goal was active (``rostopic hz`` while driving);
- ``is_anonymous``: a node name made by rospy's anonymous=True (a tool's node, left out
  of the per-node checks);
- ``cpu_percent``: CPU seconds over wall seconds of a process, as top shows it (% of one
  core), and per simulated second;
- ``waypoint_laps``: the cruise's laps from move_base's goals and results: a lap ends
  when the goal of the route's last waypoint succeeds (``lap_boundaries`` cuts the truth
  path at those times); the rule whenever goals to the waypoints were seen;
- ``split_laps``: the fallback without waypoint goals (a teleoperated robot, no
  --waypoints): the truth path cut at each return through a gate (a point on the
  circuit, e.g. the first waypoint) after having left it;
- ``dock_visits``: the spans where the robot stood (speed below ``stop_speed``) within
  ``radius`` of the dock pose;
- ``build_report`` / ``check_rows`` / ``format_table``: the JSON report and the table of
  metric, value, threshold and PASS / FAIL;
- ``draw_laps`` and ``draw_time_series``: the two pictures (OpenCV, no matplotlib), as
  BGR arrays; ``encode_png`` gives the bytes for summit_nav_common.files.write_atomic.
"""
import math
import re
from dataclasses import dataclass, field

import cv2
import numpy as np

from summit_nav_common.geometry import relative
from summit_nav_common.route import RouteError, parse_pose, read_route

# The tutorial's thresholds (section 7.1), and SPEC.md's memory bound for every node.
LOCALIZATION_MEDIAN_MAX = 0.1   # [m] "localization error < 0.1 m"
LOCALIZATION_WORST_MAX = 0.2    # [m] issue 40: no pose estimate worse than this
PLANNING_TIME_MAX = 1.0         # [s] "path planning time < 1.0 s"
CONTROL_RATE_MIN = 10.0         # [Hz] "control rate >= 10 Hz"
CPU_PERCENT_MAX = 70.0          # [% of one core] "CPU < 70 %"
PEAK_MEMORY_MAX = 1024.0        # [MB] SPEC.md: every node under 1 GB resident

TRUTH_MAX_GAP = 0.5       # [s] a truth sample farther than this from a stamp does not count
RATE_WINDOW = 1.0         # [s] of simulated time per control-rate window
DOCK_RADIUS = 0.3         # [m] the simulator's charger: robot stopped within 0.3 m of the dock
STOP_SPEED = 0.02         # [m/s] below this the robot stands (the truth's speed)
GATE_RADIUS = 1.0         # [m] passing this close to the lap gate completes a lap...
GATE_LEAVE = 3.0          # [m] ...once the robot has been this far from it since the last pass
WAYPOINT_TOL = 0.05       # [m] a move_base goal this close to a waypoint is that waypoint's goal
GOAL_SUCCEEDED = 3        # actionlib_msgs/GoalStatus.SUCCEEDED
RULE_WAYPOINTS, RULE_GATE = "waypoints", "gate"
ANONYMOUS_NAME = re.compile(r"_\d+_\d+$")   # rospy's anonymous=True suffix: _<pid>_<ms stamp>
ANONYMOUS_WHY = "anonymous (a tool's node)"

PASS, FAIL, NO_DATA, INFO = "PASS", "FAIL", "no data", ""


class HealthError(ValueError):
    """Bad input to the report (a dock that is not x,y,yaw_deg, a waypoints file without
    a dock); the message names the argument or file."""


@dataclass
class Recording:
    """What the adapter collected, in simulated seconds [s] unless named otherwise.

    Each list holds tuples, appended by the subscribers:
    amcl: (stamp, x [m], y [m], yaw [rad]); truth: (stamp, x, y, yaw, speed [m/s]);
    plan_times: (t, last plan time [s]) per new planning attempt; plan_max: (t, max plan
    time [s]) each time move_base's longest rose during the report (PlanSampler); cmd_vel:
    receive times; goal_active: (t, active bool) at each /move_base/status message;
    battery: (t, percentage 0-1, charging bool); goals: (t, goal id, x [m], y [m]) of each
    move_base goal sent (its target in the map frame); results: (t, goal id, status) of
    each move_base result (actionlib_msgs/GoalStatus codes).
    """

    amcl: list = field(default_factory=list)
    truth: list = field(default_factory=list)
    plan_times: list = field(default_factory=list)
    plan_max: list = field(default_factory=list)
    cmd_vel: list = field(default_factory=list)
    goal_active: list = field(default_factory=list)
    battery: list = field(default_factory=list)
    goals: list = field(default_factory=list)
    results: list = field(default_factory=list)


# --- statistics ------------------------------------------------------------------------

def stats(values):
    """{"samples", "median", "p95", "worst"} of a sample (NaNs dropped); the three figures
    are None for an empty sample."""
    v = np.asarray(values, dtype=np.float64).reshape(-1)
    v = v[np.isfinite(v)]
    if v.size == 0:
        return {"samples": 0, "median": None, "p95": None, "worst": None}
    return {"samples": int(v.size), "median": float(np.median(v)),
            "p95": float(np.percentile(v, 95)), "worst": float(v.max())}


def _number(text):
    """A DiagnosticStatus value as a float, None for "n/a", a missing key or junk."""
    try:
        return float(text)
    except (TypeError, ValueError):
        return None


class PlanSampler:
    """Planning times from move_base's "Global planner" statuses, which repeat the latest
    attempt's time at each publication (once per diagnostic period).

    observe(name, values) takes one status (its name, {key: value text}) and returns
    (last, worst): last [s] the latest attempt's time when the count of attempts
    ("plans" + "failed attempts") changed since the previous status of that name, else
    None; worst [s] move_base's "max plan time [s]" when it rose, else None. The first
    status of a name is the baseline (its attempts may predate the report), unless it
    has made no attempt yet; a count that goes down is a restarted move_base, whose
    attempts are all new. Attempts between two statuses leave one sample (the latest),
    but the longest of them still reaches the worst through the max.
    """

    def __init__(self):
        self._seen = {}   # status name -> (attempts, max plan time [s] or None)

    def observe(self, name, values):
        plans, failed = _number(values.get("plans")), _number(values.get("failed attempts"))
        if plans is None or failed is None:
            return None, None
        count, longest = int(plans + failed), _number(values.get("max plan time [s]"))
        prev = self._seen.get(name)
        self._seen[name] = (count, longest)
        if prev is None:
            if count > 0:
                return None, None   # the baseline: these attempts may predate the report
            prev = (0, None)
        if count < prev[0]:
            prev = (0, None)        # move_base restarted
        last = _number(values.get("last plan time [s]")) if count != prev[0] else None
        rose = longest is not None and (prev[1] is None or longest > prev[1])
        return last, longest if rose else None


def is_anonymous(node_name):
    """True for a node name that rospy's anonymous=True made (it ends in _<pid>_<stamp>,
    e.g. /bench_race_track_31721_1795847153881, /rostopic_4242_1700000000000): a tool's
    node, whose CPU and memory the report lists as not measured."""
    return bool(ANONYMOUS_NAME.search(str(node_name)))


def interpolate_track(t_query, t, x, y, yaw, max_gap=TRUTH_MAX_GAP):
    """(x, y, yaw) of a track (t ascending [s]) at each of t_query, each an array; linear
    between the two samples around a query (yaw along the shorter arc, wrapped to
    [-pi, pi)); NaN where the query lies outside the track or a neighbour is more than
    max_gap [s] away."""
    tq = np.asarray(t_query, dtype=np.float64).reshape(-1)
    t = np.asarray(t, dtype=np.float64).reshape(-1)
    nan = np.full(tq.shape, np.nan)
    if t.size == 0:
        return nan, nan.copy(), nan.copy()
    x, y = np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64)
    yaw_u = np.unwrap(np.asarray(yaw, dtype=np.float64))
    hi = np.clip(np.searchsorted(t, tq, side="left"), 0, t.size - 1)
    lo = np.clip(hi - 1, 0, t.size - 1)
    exact = t[hi] == tq
    lo = np.where(exact, hi, lo)
    span = t[hi] - t[lo]
    w = np.where(span > 0, (tq - t[lo]) / np.where(span > 0, span, 1.0), 0.0)
    ok = (tq >= t[0]) & (tq <= t[-1]) & (tq - t[lo] <= max_gap) & (t[hi] - tq <= max_gap)
    xi = np.where(ok, x[lo] + w * (x[hi] - x[lo]), np.nan)
    yi = np.where(ok, y[lo] + w * (y[hi] - y[lo]), np.nan)
    yawi = yaw_u[lo] + w * (yaw_u[hi] - yaw_u[lo])
    yawi = np.where(ok, (yawi + math.pi) % (2 * math.pi) - math.pi, np.nan)
    return xi, yi, yawi


def localization_errors(amcl, truth, max_gap=TRUTH_MAX_GAP):
    """(position error [m], heading error [rad]) arrays of amcl poses (N, 4: stamp, x, y,
    yaw) against the truth track (M, >= 4: stamp, x, y, yaw, ...) at each pose's stamp;
    NaN where the truth does not cover the stamp."""
    a = np.asarray(amcl, dtype=np.float64).reshape(-1, 4)
    tr = np.asarray(truth, dtype=np.float64)
    if tr.size == 0:
        return np.full(len(a), np.nan), np.full(len(a), np.nan)
    tr = tr[np.argsort(tr[:, 0], kind="stable")]
    x, y, yaw = interpolate_track(a[:, 0], tr[:, 0], tr[:, 1], tr[:, 2], tr[:, 3], max_gap)
    pos = np.hypot(a[:, 1] - x, a[:, 2] - y)
    head = np.abs((a[:, 3] - yaw + math.pi) % (2 * math.pi) - math.pi)
    return pos, head


def active_intervals(status, t_end):
    """[(t0, t1)] where a goal was active, from (t, active) samples in time order; an
    interval still open at the last sample ends at t_end [s]."""
    out, start = [], None
    for t, active in status:
        if active and start is None:
            start = t
        elif not active and start is not None:
            out.append((start, t))
            start = None
    if start is not None and t_end > start:
        out.append((start, t_end))
    return out


def window_rates(times, intervals, window=RATE_WINDOW):
    """Messages per second [Hz] in each whole window [s] of consecutive windows laid from
    the start of each interval (t0, t1) [s]; a window that would run past t1 is left out."""
    t = np.sort(np.asarray(times, dtype=np.float64).reshape(-1))
    rates = []
    for t0, t1 in intervals:
        n = int(math.floor((t1 - t0) / window + 1e-9))
        if n <= 0:
            continue
        edges = t0 + window * np.arange(n + 1)
        counts = np.diff(np.searchsorted(t, edges, side="left"))
        rates.extend((counts / window).tolist())
    return np.asarray(rates, dtype=np.float64)


def cpu_percent(first, last):
    """(CPU [% of one core] over wall time, CPU seconds per simulated second) between two
    samples (wall [s], sim [s], cpu [s]) of one process; None for a figure whose span is
    not positive."""
    dw, ds, dc = (last[i] - first[i] for i in range(3))
    return (100.0 * dc / dw if dw > 0 else None, dc / ds if ds > 0 else None)


# --- laps and dock ---------------------------------------------------------------------

def split_laps(xy, gate, gate_radius=GATE_RADIUS, leave=GATE_LEAVE, finish=None):
    """Indices of the path's (N, 2 [m]) lap boundaries: in each pass within gate_radius of
    gate (x, y) made after having been more than leave [m] from it since the previous
    boundary, the sample closest to the gate (so every lap is cut at the same place);
    the pass the path starts in is a boundary too. finish (x, y), when given and not the
    gate (a cruise whose lap runs from its first waypoint to its last), ends the last lap:
    the closest approach to it after the last boundary, once the robot was more than leave
    from both. The samples before the first boundary lead in, those after the last are an
    unfinished lap."""
    xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    if len(xy) == 0:
        return []
    d = np.hypot(xy[:, 0] - gate[0], xy[:, 1] - gate[1])
    inside = d <= gate_radius
    bounds, armed, i, n = [], True, 0, len(d)
    while i < n:
        if not inside[i]:
            armed = armed or d[i] > leave
            i += 1
            continue
        j = i
        while j + 1 < n and inside[j + 1]:
            j += 1
        if armed or i == 0:
            bounds.append(i + int(np.argmin(d[i:j + 1])))
            armed = False
        i = j + 1
    if finish is not None and bounds and math.hypot(finish[0] - gate[0], finish[1] - gate[1]) > gate_radius:
        last = bounds[-1]
        df = np.hypot(xy[last:, 0] - finish[0], xy[last:, 1] - finish[1])
        away = np.flatnonzero((d[last:] > leave) & (df > leave))
        if len(away):
            near = np.flatnonzero(df[away[0]:] <= gate_radius)
            if len(near):
                k = away[0] + near[0]
                run_end = k + (np.flatnonzero(df[k:] > gate_radius)[0] if np.any(df[k:] > gate_radius)
                               else len(df) - k)
                bounds.append(last + k + int(np.argmin(df[k:run_end])))
    return bounds


def waypoint_laps(goals, results, waypoints, tol=WAYPOINT_TOL):
    """Lap boundary times [s] of a cruise over waypoints [(x, y) [m], in driving order],
    from move_base's goals [(t, goal id, x, y)] and results [(t, goal id, status)].

    A goal is a waypoint's when its target lies within tol [m] of it (the nearest; a
    target at two waypoints, a route whose last waypoint repeats its first, is the last
    one when goals to other waypoints were sent since the previous boundary, else the
    first); other goals (the dock, home, a goal sent by hand) are ignored. A result is
    matched to its goal by goal id. Boundaries, in time order:

    - the first goal to the first waypoint starts the first lap (when the report began
      mid-lap, the first lap starts at the end of that partial one instead);
    - the SUCCEEDED result of the last waypoint's goal ends a lap and starts the next
      (one boundary per lap: only a goal sent since the previous boundary ends one);
    - a lap whose last waypoint was skipped (its goals failed and the cruise gave up on
      it) ends when the next lap's first goal, to the first waypoint, is sent after goals
      to other waypoints since the previous boundary; if the run ends instead, that lap
      stays unfinished (the cruise's own count has it, this one does not).

    Retries and the resumption after a dock visit re-send the same waypoint and start
    nothing. A result that comes no later than its goal (same stamp) is taken after it.
    """
    wp = np.asarray(waypoints, dtype=np.float64).reshape(-1, 2)
    if not len(wp):
        return []
    last = len(wp) - 1
    sent_at = {}
    for t, gid, _x, _y in goals:
        sent_at.setdefault(gid, t)
    events = [(float(t), 1, k, ("goal", gid, x, y)) for k, (t, gid, x, y) in enumerate(goals)]
    for k, (t, gid, status) in enumerate(results):
        t0 = sent_at.get(gid)
        key = (float(t), 0) if t0 is None or t0 < t else (float(t0), 2)
        events.append(key + (k, ("result", gid, status)))
    events.sort(key=lambda e: e[:3])
    bounds, goal_index, goal_seq = [], {}, {}
    others, seq, seq_at_bound = False, 0, 0    # a goal to another waypoint since the boundary
    for t, _, _, ev in events:
        if ev[0] == "goal":
            _, gid, x, y = ev
            seq += 1
            d = np.hypot(wp[:, 0] - x, wp[:, 1] - y)
            near = np.flatnonzero(d <= tol)
            if not len(near):
                continue
            close = near[d[near] <= d[near].min() + 1e-9]
            i = int(close.max() if others else close.min())
            goal_index[gid], goal_seq[gid] = i, seq
            if i == 0 and (not bounds or others):
                bounds.append(t)
                others, seq_at_bound = False, seq - 1   # this goal is of the new lap
            elif i != 0:
                others = True
        else:
            _, gid, status = ev
            if status == GOAL_SUCCEEDED and goal_index.get(gid) == last and goal_seq[gid] > seq_at_bound:
                bounds.append(t)
                others, seq_at_bound = False, seq
    return bounds


def waypoint_goal_count(goals, waypoints, tol=WAYPOINT_TOL):
    """How many of the goals [(t, goal id, x, y)] are to one of the waypoints [(x, y)]."""
    wp = np.asarray(waypoints, dtype=np.float64).reshape(-1, 2)
    if not len(wp):
        return 0
    return sum(1 for _t, _gid, x, y in goals if np.any(np.hypot(wp[:, 0] - x, wp[:, 1] - y) <= tol))


def lap_boundaries(truth, goals=(), results=(), waypoints=None, gate=None, finish=None):
    """(rule, boundary times [s], indices into truth) of the laps of a sorted truth track
    (N, >= 3: stamp, x, y, ...): RULE_WAYPOINTS (waypoint_laps; each time's index is the
    first truth sample at or after it) when waypoints are given and a goal to one of them
    was seen, else RULE_GATE (split_laps through gate, default the first truth position,
    and finish)."""
    truth = np.asarray(truth, dtype=np.float64)
    if waypoints is not None and len(waypoints) and waypoint_goal_count(goals, waypoints):
        times = waypoint_laps(goals, results, waypoints)
        idx = np.searchsorted(truth[:, 0], times, side="left") if len(truth) else np.zeros(len(times), int)
        return RULE_WAYPOINTS, [float(v) for v in times], [int(min(i, max(0, len(truth) - 1))) for i in idx]
    if gate is None and len(truth):
        gate = tuple(truth[0, 1:3])
    bounds = split_laps(truth[:, 1:3], gate, finish=finish) if gate is not None else []
    return RULE_GATE, [float(truth[b, 0]) for b in bounds], bounds


def dock_visits(t, xy, speed, dock, radius=DOCK_RADIUS, stop_speed=STOP_SPEED):
    """[(t_in, t_out)] [s] of each visit to the dock (x, y[, yaw]): a stay within radius
    [m] of it during which the robot stood (speed [m/s] below stop_speed) at least once;
    t_in/t_out are the first and last samples of the stay. A stay the path starts in is
    where the robot was when the report began, not a visit."""
    t = np.asarray(t, dtype=np.float64).reshape(-1)
    xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    speed = np.asarray(speed, dtype=np.float64).reshape(-1)
    inside = np.hypot(xy[:, 0] - dock[0], xy[:, 1] - dock[1]) <= radius
    visits, i, n = [], 0, len(t)
    while i < n:
        if not inside[i]:
            i += 1
            continue
        j = i
        while j + 1 < n and inside[j + 1]:
            j += 1
        if i > 0 and np.any(speed[i:j + 1] < stop_speed):
            visits.append((float(t[i]), float(t[j])))
        i = j + 1
    return visits


def truth_in_map(truth, map_in_world):
    """The truth samples (N, 5: stamp, x, y, yaw, speed) taken from the simulator's world
    frame into the map frame, whose pose in the world is map_in_world (x [m], y [m],
    yaw [rad]): map_pose = inverse(map_in_world) (+) world_pose. The identity when the map
    is the world (a world image served as the map, as on the race track); the course's
    committed SLAM map sits at the spawn pose (2, 7, 0)."""
    tr = np.array(truth, dtype=np.float64).reshape(-1, 5)
    if len(tr):
        tr[:, 1:4] = relative(map_in_world, tr[:, 1:4])
    return tr


def parse_pose_arg(text, flag):
    """(x [m], y [m], yaw [rad]) of a command-line pose "x,y,yaw_deg"; HealthError naming
    the flag otherwise."""
    try:
        x, y, yaw_deg = parse_pose(str(text).split(","))
    except ValueError:
        raise HealthError(f"{flag} {text!r}: expected x,y,yaw_deg (three numbers, e.g. 1.5,-2,90)") from None
    return x, y, math.radians(yaw_deg)


def parse_dock(text):
    """(x [m], y [m], yaw [rad]) of a --dock argument "x,y,yaw_deg"; HealthError otherwise."""
    return parse_pose_arg(text, "--dock")


def read_waypoints(path):
    """(dock, first waypoint, last waypoint), each (x [m], y [m], yaw [rad]) or None, of a
    route file (summit_nav_common.route; its waypoints may be missing). HealthError naming
    the file and the entry when the file cannot be read or one of the three is malformed."""
    try:
        route = read_route(path, need_waypoints=False)
        ends = (route.waypoints[0], route.waypoints[-1]) if route.waypoints else (None, None)
        poses = [None if e is None else e.checked() for e in (route.dock,) + ends]
    except RouteError as e:
        raise HealthError(f"--waypoints {e}") from None
    return tuple(None if p is None else (p[0], p[1], math.radians(p[2])) for p in poses)


def read_route_points(path):
    """[(x [m], y [m])] of a route file's well-formed waypoints, in driving order (the
    cruise skips a malformed one every lap, so it is no lap's first or last); HealthError
    naming the file when it cannot be read."""
    try:
        route = read_route(path, need_waypoints=False)
    except RouteError as e:
        raise HealthError(f"--waypoints {e}") from None
    return [(float(e.pose[0]), float(e.pose[1])) for e in route.waypoints if e.error is None]


# --- the report ------------------------------------------------------------------------

def _round(v, nd=4):
    return None if v is None else round(float(v), nd)


def by_time(rows, width):
    """Rows of a Recording list as an (N, width) float array sorted by their first column
    (time [s]); the subscribers' threads may append out of order."""
    a = np.asarray(rows, dtype=np.float64).reshape(-1, width)
    return a[np.argsort(a[:, 0], kind="stable")]


def build_report(rec, t_start, t_end, nodes=None, dock=None, gate=None, summary=None, finish=None,
                 waypoints=None):
    """The health.json dictionary of a Recording between t_start and t_end (simulated [s]).

    nodes: {name: {"pid", "cpu_percent", "cpu_s_per_sim_s", "peak_rss_mb"}} from the
    adapter; dock: (x, y, yaw [rad]) or None; waypoints: [(x, y)] of the cruise's route,
    whose goals and results (rec.goals, rec.results) give the laps (waypoint_laps); gate:
    (x, y) of the lap gate when no goal to a waypoint was seen, default the first truth
    position; finish: (x, y) where the last lap ends (split_laps), default the gate;
    summary: the cruise node's parsed summary or None. report["laps"]["rule"] says which
    rule counted the laps.
    """
    truth = by_time(rec.truth, 5)
    pos_err, head_err = localization_errors(rec.amcl, truth)
    loc = stats(pos_err)
    head = stats(np.degrees(head_err))
    plan = stats([p for _, p in rec.plan_times])
    plan_max = [m for _, m in rec.plan_max if math.isfinite(m)]
    if plan_max:   # a plan between two statuses: only move_base's max saw it
        plan["worst"] = max(plan_max + ([plan["worst"]] if plan["worst"] is not None else []))
    intervals = active_intervals(rec.goal_active, t_end)
    rates = window_rates(rec.cmd_vel, intervals)
    battery = np.asarray(rec.battery, dtype=np.float64).reshape(-1, 3)

    report = {
        "sim_time_s": _round(t_end - t_start, 2),
        "localization": {"samples": loc["samples"], "median_m": _round(loc["median"]),
                         "p95_m": _round(loc["p95"]), "worst_m": _round(loc["worst"]),
                         "heading_median_deg": _round(head["median"], 2),
                         "heading_worst_deg": _round(head["worst"], 2)},
        "planning": {"samples": plan["samples"], "median_s": _round(plan["median"]),
                     "p95_s": _round(plan["p95"]), "worst_s": _round(plan["worst"])},
        "control_rate": {"windows": int(rates.size),
                         "goal_active_s": _round(sum(b - a for a, b in intervals), 2),
                         "mean_hz": _round(rates.mean(), 2) if rates.size else None,
                         "p5_hz": _round(np.percentile(rates, 5), 2) if rates.size else None},
        "nodes": nodes or {},
        "battery": {"samples": int(len(battery)),
                    "start_percent": _round(100 * battery[0, 1], 1) if len(battery) else None,
                    "end_percent": _round(100 * battery[-1, 1], 1) if len(battery) else None,
                    "min_percent": _round(100 * battery[:, 1].min(), 1) if len(battery) else None},
    }
    xy = truth[:, 1:3]
    steps = np.hypot(*np.diff(xy, axis=0).T) if len(xy) > 1 else np.zeros(0)
    report["motion"] = {"distance_m": _round(steps.sum(), 2),
                        "mean_speed_m_s": _round(truth[:, 4].mean(), 3) if len(truth) else None,
                        "max_speed_m_s": _round(truth[:, 4].max(), 3) if len(truth) else None}
    if gate is None and len(truth):
        gate = tuple(truth[0, 1:3])
    rule, times, _ = lap_boundaries(truth, rec.goals, rec.results, waypoints, gate, finish)
    by_gate = rule == RULE_GATE
    report["laps"] = {"rule": rule,
                      "completed": max(0, len(times) - 1),
                      "times_s": [_round(b - a, 2) for a, b in zip(times, times[1:])],
                      "boundaries_s": [_round(b - t_start, 2) for b in times],
                      "waypoints": len(waypoints) if waypoints is not None else None,
                      "waypoint_goals": waypoint_goal_count(rec.goals, waypoints) if waypoints is not None else None,
                      "gate": [_round(gate[0], 3), _round(gate[1], 3)] if by_gate and gate is not None else None,
                      "finish": None if not by_gate or finish is None else [_round(finish[0], 3),
                                                                           _round(finish[1], 3)]}
    visits = dock_visits(truth[:, 0], xy, truth[:, 4], dock) if dock is not None else []
    report["dock"] = {
        "pose": None if dock is None else [_round(dock[0], 3), _round(dock[1], 3), _round(math.degrees(dock[2]), 1)],
        "visits": [{"t_in_s": _round(a - t_start, 2), "t_out_s": _round(b - t_start, 2),
                    "stay_s": _round(b - a, 2),
                    "battery_in_percent": _battery_at(battery, a), "battery_out_percent": _battery_at(battery, b)}
                   for a, b in visits]}
    report["auto_navigator_summary"] = summary
    report["checks"] = [dict(zip(("metric", "value", "threshold", "result"), row)) for row in check_rows(report)]
    report["passed"] = all(c["result"] != FAIL for c in report["checks"])
    return report


def _battery_at(battery, t):
    """Battery [%] of the last sample at or before t [s] (the first one before any), or None."""
    if not len(battery):
        return None
    i = max(0, int(np.searchsorted(battery[:, 0], t, side="right")) - 1)
    return _round(100 * battery[i, 1], 1)


def _check(name, value, op, limit, unit, fmt="{:.3f}"):
    """One table row; op is "<" or ">=" against limit."""
    threshold = f"{op} {limit:g}{unit}"
    if value is None:
        return name, "-", threshold, NO_DATA
    ok = value < limit if op == "<" else value >= limit
    return name, fmt.format(value), threshold, PASS if ok else FAIL


def check_rows(report):
    """[(metric, value text, threshold text, PASS / FAIL / "no data" / "")] of a report:
    the tutorial's thresholds, then figures given for information ("" result)."""
    loc, plan, rate = report["localization"], report["planning"], report["control_rate"]
    rows = [
        _check("localization error median [m]", loc["median_m"], "<", LOCALIZATION_MEDIAN_MAX, " m"),
        ("localization error p95 [m]", "-" if loc["p95_m"] is None else f"{loc['p95_m']:.3f}", "", INFO),
        _check("localization error worst [m]", loc["worst_m"], "<", LOCALIZATION_WORST_MAX, " m"),
        _check("planning time worst [s]", plan["worst_s"], "<", PLANNING_TIME_MAX, " s"),
        ("planning time median [s]", "-" if plan["median_s"] is None else f"{plan['median_s']:.3f}", "", INFO),
        _check("control rate mean [Hz]", rate["mean_hz"], ">=", CONTROL_RATE_MIN, " Hz", "{:.1f}"),
        ("control rate p5 [Hz]", "-" if rate["p5_hz"] is None else f"{rate['p5_hz']:.1f}", "", INFO),
    ]
    for name, node in sorted(report["nodes"].items()):
        rows.append(_check(f"CPU {name} [% core]", node.get("cpu_percent"), "<", CPU_PERCENT_MAX, " %", "{:.1f}"))
        rows.append(_check(f"peak memory {name} [MB]", node.get("peak_rss_mb"), "<", PEAK_MEMORY_MAX, " MB",
                           "{:.0f}"))
    bat = report["battery"]
    rows.append(("battery start / end / min [%]",
                 "-" if bat["start_percent"] is None
                 else f"{bat['start_percent']:.0f} / {bat['end_percent']:.0f} / {bat['min_percent']:.0f}", "", INFO))
    rows.append(("distance driven [m]", f"{report['motion']['distance_m']:.1f}", "", INFO))
    laps = report["laps"]
    how = "by waypoint goals" if laps["rule"] == RULE_WAYPOINTS else "by gate passes"
    rows.append((f"laps completed ({how})", str(laps["completed"]), "", INFO))
    if laps["times_s"]:
        rows.append(("lap time mean [s]", f"{np.mean(laps['times_s']):.1f}", "", INFO))
    if report["dock"]["pose"] is not None:
        rows.append(("dock visits", str(len(report["dock"]["visits"])), "", INFO))
    return rows


def format_table(rows):
    """The rows as a fixed-width text table with a header line."""
    head = ("metric", "value", "threshold", "result")
    widths = [max(len(str(r[i])) for r in [head] + list(rows)) for i in range(4)]
    line = "  ".join("{:<%d}" % w for w in widths)
    out = [line.format(*head), "  ".join("-" * w for w in widths)]
    out += [line.format(*(str(c) for c in r)).rstrip() for r in rows]
    return "\n".join(out)


# --- pictures --------------------------------------------------------------------------

FONT = cv2.FONT_HERSHEY_SIMPLEX
INK = (40, 40, 40)          # BGR of text and axes
GRID_INK = (225, 225, 225)  # BGR of grid lines
# lap colours (BGR), distinct for up to ten laps, then repeated
LAP_COLOURS = [(180, 119, 31), (14, 127, 255), (44, 160, 44), (40, 39, 214), (189, 103, 148),
               (75, 86, 140), (194, 119, 227), (34, 189, 188), (207, 190, 23), (127, 127, 127)]
LEAD_IN = (170, 170, 170)   # BGR of the path outside complete laps
PICTURE_SIDE = 800          # [px] the larger side of the map area of laps.png
LEGEND_WIDTH = 170          # [px] the legend column right of the map


def nice_ticks(lo, hi, n=5):
    """About n round tick values (1, 2, 2.5 or 5 x 10^k apart) within [lo, hi]."""
    if not (math.isfinite(lo) and math.isfinite(hi)) or hi <= lo:
        return [lo]
    raw = (hi - lo) / max(1, n)
    mag = 10 ** math.floor(math.log10(raw))
    step = next(m * mag for m in (1, 2, 2.5, 5, 10) if m * mag >= raw)
    first = math.ceil(lo / step - 1e-9) * step
    return [round(first + k * step, 10) for k in range(int(math.floor((hi - first) / step + 1e-9)) + 1)]


def round_down_125(v):
    """The largest 1, 2 or 5 x 10^k not above v (v > 0)."""
    mag = 10 ** math.floor(math.log10(v))
    return max(m * mag for m in (1, 2, 5) if m * mag <= v * (1 + 1e-9))


def _tick_text(v):
    return f"{v:g}" if abs(v) < 1e5 else f"{v:.0e}"


def draw_time_series(panels, width=820, panel_height=230, xlabel="simulated time [s]"):
    """A BGR picture of panels stacked vertically over a shared x axis. Each panel is a
    dict: title, ylabel, series [(t array [s], y array, BGR colour)], optional ylim
    (lo, hi) and note (a text drawn in the panel, e.g. "no data")."""
    left, right, top, bottom = 70, 20, 30, 45
    img = np.full((len(panels) * panel_height, width, 3), 255, np.uint8)
    ts = [np.asarray(t, float) for p in panels for t, _, _ in p["series"] if len(t)]
    t_lo = min((t.min() for t in ts), default=0.0)
    t_hi = max((t.max() for t in ts), default=1.0)
    if t_hi <= t_lo:
        t_hi = t_lo + 1.0
    x0, x1 = left, width - right
    for k, p in enumerate(panels):
        oy = k * panel_height
        y0, y1 = oy + top, oy + panel_height - bottom
        ys = [np.asarray(y, float) for t, y, _ in p["series"] if len(t)]
        lo, hi = p.get("ylim") or (min((y.min() for y in ys), default=0.0), max((y.max() for y in ys), default=1.0))
        if hi <= lo:
            lo, hi = lo - 0.5, hi + 0.5

        def px(t, y, lo=lo, hi=hi, y0=y0, y1=y1):
            return (np.round(x0 + (np.asarray(t) - t_lo) / (t_hi - t_lo) * (x1 - x0)).astype(np.int32),
                    np.round(y1 - (np.asarray(y) - lo) / (hi - lo) * (y1 - y0)).astype(np.int32))

        for v in nice_ticks(lo, hi, 4):
            _, yy = px(t_lo, v)
            cv2.line(img, (x0, int(yy)), (x1, int(yy)), GRID_INK, 1)
            cv2.line(img, (x0 - 4, int(yy)), (x0, int(yy)), INK, 1)
            txt = _tick_text(v)
            (tw, th), _ = cv2.getTextSize(txt, FONT, 0.4, 1)
            cv2.putText(img, txt, (x0 - 8 - tw, int(yy) + th // 2), FONT, 0.4, INK, 1, cv2.LINE_AA)
        for v in nice_ticks(t_lo, t_hi, 8):
            xx, _ = px(v, lo)
            cv2.line(img, (int(xx), y0), (int(xx), y1), GRID_INK, 1)
            cv2.line(img, (int(xx), y1), (int(xx), y1 + 4), INK, 1)
            txt = _tick_text(v)
            (tw, th), _ = cv2.getTextSize(txt, FONT, 0.4, 1)
            cv2.putText(img, txt, (int(xx) - tw // 2, y1 + 8 + th), FONT, 0.4, INK, 1, cv2.LINE_AA)
        cv2.rectangle(img, (x0, y0), (x1, y1), INK, 1)
        for t, y, colour in p["series"]:
            if len(t) > 1:
                xs, yv = px(t, np.clip(y, lo, hi))
                cv2.polylines(img, [np.stack([xs, yv], axis=1)], False, colour, 2, cv2.LINE_AA)
        cv2.putText(img, f"{p['title']}   ({p['ylabel']})", (x0, oy + 20), FONT, 0.5, INK, 1, cv2.LINE_AA)
        if p.get("note"):
            cv2.putText(img, p["note"], (x0 + 12, y0 + 24), FONT, 0.5, (0, 0, 200), 1, cv2.LINE_AA)
        (tw, _), _ = cv2.getTextSize(xlabel, FONT, 0.45, 1)
        cv2.putText(img, xlabel, ((x0 + x1 - tw) // 2, oy + panel_height - 8), FONT, 0.45, INK, 1, cv2.LINE_AA)
    return img


def draw_laps(grid, path_xy, bounds, dock=None, visits_xy=(), title="", side=PICTURE_SIDE):
    """A BGR picture of the map (a summit_nav_common.map_io.GridMap, or None for a blank
    ground) cropped to its known cells and the path, with the truth path (N, 2 [m]) drawn
    lap by lap (truth indices of the lap boundaries from lap_boundaries; lead-in and unfinished lap in grey), the dock
    (x, y, yaw [rad]) as a square with its heading, and each dock visit (x, y) as a
    numbered circle. A legend names the laps, and a scale bar gives metres."""
    path_xy = np.asarray(path_xy, float).reshape(-1, 2)
    pts = [path_xy] + ([np.asarray([dock[:2]])] if dock is not None else [])
    if grid is not None:
        res = grid.resolution
        ox, oy, oyaw = grid.origin
        known = np.argwhere(grid.data >= 0)
        if len(known):
            r0, c0 = known.min(axis=0)
            r1, c1 = known.max(axis=0) + 1
            c, s = math.cos(oyaw), math.sin(oyaw)
            corners = np.array([[c0, r0], [c1, r0], [c0, r1], [c1, r1]], float) * res
            pts.append(np.stack([ox + c * corners[:, 0] - s * corners[:, 1],
                                 oy + s * corners[:, 0] + c * corners[:, 1]], axis=1))
    allpts = np.concatenate([p for p in pts if len(p)]) if any(len(p) for p in pts) else np.zeros((1, 2))
    margin = 1.0   # [m] around the drawn area
    lo, hi = allpts.min(axis=0) - margin, allpts.max(axis=0) + margin
    scale = side / max(hi - lo)   # [px/m]
    w, h = int(math.ceil((hi[0] - lo[0]) * scale)), int(math.ceil((hi[1] - lo[1]) * scale))
    img = np.full((h, w, 3), 255, np.uint8)

    def px(x, y):
        return (np.round((np.asarray(x) - lo[0]) * scale).astype(np.int32),
                np.round(h - (np.asarray(y) - lo[1]) * scale).astype(np.int32))

    if grid is not None:
        grey = np.where(grid.data == 100, 0, np.where(grid.data < 0, 205,
                                                      255 - np.clip(grid.data, 0, 100) * 2)).astype(np.uint8)
        # the map's cell corners in picture pixels: an affine warp (origin yaw included)
        c, s = math.cos(grid.origin[2]), math.sin(grid.origin[2])
        res = grid.resolution
        a = np.array([[c * res * scale, -s * res * scale, (grid.origin[0] - lo[0]) * scale],
                      [-s * res * scale, -c * res * scale, h - (grid.origin[1] - lo[1]) * scale]])
        img = cv2.cvtColor(cv2.warpAffine(grey, a, (w, h), flags=cv2.INTER_NEAREST,
                                          borderValue=255), cv2.COLOR_GRAY2BGR)
    cuts = [0] + list(bounds) + [len(path_xy)]
    legend = []
    for a, b in zip(cuts, cuts[1:]):
        seg = path_xy[a:b + 1]
        if len(seg) < 2:
            continue
        complete = a in bounds and b in bounds
        colour = LAP_COLOURS[len(legend) % len(LAP_COLOURS)] if complete else LEAD_IN
        xs, ys = px(seg[:, 0], seg[:, 1])
        cv2.polylines(img, [np.stack([xs, ys], axis=1)], False, colour, 2, cv2.LINE_AA)
        if complete:
            legend.append((f"lap {len(legend) + 1}", colour))
    if dock is not None:
        cx, cy = px(dock[0], dock[1])
        half = max(4, int(round(DOCK_RADIUS * scale)))
        cv2.rectangle(img, (int(cx) - half, int(cy) - half), (int(cx) + half, int(cy) + half), (0, 140, 0), 2)
        hx, hy = px(dock[0] + 0.5 * math.cos(dock[2]), dock[1] + 0.5 * math.sin(dock[2]))
        cv2.arrowedLine(img, (int(cx), int(cy)), (int(hx), int(hy)), (0, 140, 0), 2, cv2.LINE_AA, tipLength=0.3)
        cv2.putText(img, "dock", (int(cx) + half + 4, int(cy) - half), FONT, 0.5, (0, 120, 0), 1, cv2.LINE_AA)
    for i, (x, y) in enumerate(visits_xy):
        cx, cy = px(x, y)
        cv2.circle(img, (int(cx), int(cy)), 9, (0, 0, 220), 2, cv2.LINE_AA)
        cv2.putText(img, str(i + 1), (int(cx) + 10, int(cy) + 14), FONT, 0.45, (0, 0, 220), 1, cv2.LINE_AA)
    if visits_xy:
        legend.append((f"dock visits ({len(visits_xy)})", (0, 0, 220)))
    if len(legend) > len(LAP_COLOURS) + 1:   # many laps: colours repeat, so name the range
        legend = legend[:3] + [("...", INK)] + legend[-2:]
    # the legend in a white column right of the map, so it hides no part of the track
    img = np.hstack([img, np.full((h, LEGEND_WIDTH, 3), 255, np.uint8)])
    for i, (text, colour) in enumerate(legend):
        y = 44 + 18 * i
        cv2.line(img, (w + 10, y - 4), (w + 35, y - 4), colour, 3)
        cv2.putText(img, text, (w + 40, y), FONT, 0.45, INK, 1, cv2.LINE_AA)
    # scale bar: a round length near a fifth of the width
    bar = round_down_125((w / scale) / 5)
    bx, by = 12, h - 14
    cv2.line(img, (bx, by), (bx + int(bar * scale), by), INK, 3)
    cv2.putText(img, f"{bar:g} m", (bx, by - 6), FONT, 0.45, INK, 1, cv2.LINE_AA)
    cv2.putText(img, title, (10, 22), FONT, 0.55, INK, 1, cv2.LINE_AA)
    return img


def encode_png(img):
    """PNG bytes of a BGR picture."""
    ok, buf = cv2.imencode(".png", img)
    if not ok:
        raise ValueError("OpenCV could not encode the picture as PNG")
    return buf.tobytes()


BATTERY_COLOUR, SPEED_COLOUR = (0, 120, 220), (180, 90, 20)   # BGR


def pictures(report, rec, grid, dock, t0, laps_by):
    """(laps.png, battery_speed.png) as PNG bytes of a build_report report and its Recording.

    grid: the map (GridMap) or None; dock: (x, y, yaw [rad]) or None; t0: the report's start
    [s] (the plots' zero); laps_by: (gate, finish, waypoints) as build_report had them."""
    truth = by_time(rec.truth, 5)
    gate, finish, waypoints = laps_by
    _, _, bounds = lap_boundaries(truth, rec.goals, rec.results, waypoints, gate, finish)
    visits_xy = []
    for v in report["dock"]["visits"]:
        inside = (truth[:, 0] >= v["t_in_s"] + t0) & (truth[:, 0] <= v["t_out_s"] + t0)
        if inside.any():
            visits_xy.append(tuple(truth[inside, 1:3].mean(axis=0)))
    n = report["laps"]["completed"]
    title = (f"truth path: {n} lap{'s' * (n != 1)}, {report['motion']['distance_m']:.0f} m"
             + (f", {len(visits_xy)} dock visit{'s' * (len(visits_xy) != 1)}" if dock is not None else ""))
    laps_png = encode_png(draw_laps(grid, truth[:, 1:3], bounds, dock, visits_xy, title))
    bat = by_time(rec.battery, 3)
    panels = [
        {"title": "battery", "ylabel": "%", "ylim": (0, 100),
         "series": [(bat[:, 0] - t0, 100 * bat[:, 1], BATTERY_COLOUR)] if len(bat) else [],
         "note": None if len(bat) else "no /battery_state"},
        {"title": "speed (ground truth)", "ylabel": "m/s",
         "series": [(truth[:, 0] - t0, truth[:, 4], SPEED_COLOUR)] if len(truth) else [],
         "note": None if len(truth) else "no /base_pose_ground_truth"},
    ]
    return laps_png, encode_png(draw_time_series(panels))
