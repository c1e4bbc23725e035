#!/usr/bin/python3
"""Benchmark of the race track (issue 40): laps with charging stops, a box on the narrow
section, the tutorial's performance table, and the adaptive parameters on and off.

One run is `race_track.launch laps:=N speed:=S` (simulator, map_server, amcl, move_base
with TrajectoryPlannerROS, auto_navigator, the diagnostic aggregator, nav_health) on a
private ROS master, watched from here by ground truth:

- every waypoint of every lap reached or skipped with a reason (auto_navigator's summary);
- zero collisions (the simulator's /collisions);
- every low battery (the simulator's /battery_state under the cruise's low_battery)
  followed by a charge at the dock (status CHARGING) and the next waypoint goal after it
  the one the low battery interrupted (move_base's /move_base/goal, matched to the
  waypoints file);
- with --box, a box put against the wall of the narrow section ahead of the robot on its
  second lap: the robot passes it or its watchdog fires and it recovers, never touching
  it (the box is taken away when the goal it blocked ends);
- the least clearance between the footprint and a wall (the world's distance field at
  the footprint's edge points), and each lap's time;
- nav_health's report (localization error, planning time, control rate, CPU and memory
  per node against the tutorial's thresholds).

    bench_race_track.py [--laps 10] [--speed 1] [--seed 0] [--box] [--adaptive]
                        [--capacity-wh WH] [--json PATH]
"""
import argparse
import json
import math
import os
import sys
import tempfile
import threading
import time

import numpy as np
import yaml

HERE = os.path.dirname(os.path.abspath(__file__))
WS = os.path.abspath(os.path.join(HERE, "..", "..", ".."))

WAYPOINTS = os.path.join(WS, "src", "my_summit_navigation", "config", "race_track_waypoints.yaml")
WORLD = os.path.join(WS, "src", "summit_xl_sim", "worlds", "race_track.yaml")
BATTERY = os.path.join(WS, "src", "summit_xl_sim", "config", "race_track_battery.yaml")
LOW_BATTERY = 0.2       # auto_navigator's ~low_battery default
CHARGING = 1            # sensor_msgs/BatteryState.POWER_SUPPLY_STATUS_CHARGING
SUCCEEDED = 3           # actionlib_msgs/GoalStatus.SUCCEEDED
GOAL_MATCH = 0.05       # [m] a move_base goal is a waypoint when this close to it
BOX_SIZE = 0.25         # [m] a box against one wall of the narrow section
# The narrow section is 1.35 m wide at y = 1.5, x -4..1 (race_track.world.yaml); the box
# stands against its north barrier (face at y = 2.175) halfway along: 1.1 m stay free.
BOX_XY = (-1.5, 2.175 - BOX_SIZE / 2.0)   # [m] world = map frame
BOX_LAP = 2             # the lap the box is dropped on
BOX_AHEAD = 2.0         # [m] drop it when the robot is this far from it (truth)
BOX_FOR = 120.0         # [s] of simulated time at most, then it is taken away anyway
HALF_WIDTH = 0.31       # [m] the Summit XL's half width
CORNER_SLACK = 0.05     # [m] the centre distance judges two rectangles: what a corner may lean in
WALL_LIMIT_PER_LAP = 600.0   # [s] of wall-clock time per lap at 1x, at most
TRUTH_PERIOD = 0.1      # [s] of simulated time between clearance samples


def load_route(path=WAYPOINTS):
    """(waypoints [(name, x, y)], dock (x, y, yaw_deg))."""
    with open(path) as f:
        doc = yaml.safe_load(f)
    wps = [(str(w.get("name", i)), float(w["x"]), float(w["y"])) for i, w in enumerate(doc["waypoints"])]
    d = doc["dock"]
    return wps, (float(d["x"]), float(d["y"]), float(d["yaw_deg"]))


def match_goal(xy, waypoints, dock):
    """'dock', a waypoint index, or None for a move_base goal at xy."""
    if math.hypot(xy[0] - dock[0], xy[1] - dock[1]) < GOAL_MATCH:
        return "dock"
    for i, (_, x, y) in enumerate(waypoints):
        if math.hypot(xy[0] - x, xy[1] - y) < GOAL_MATCH:
            return i
    return None


def judge_battery(events, goals, n_waypoints):
    """Each low-battery event followed by a charge and a resume at the interrupted waypoint.

    events: [(t, kind)] with kind 'low' (percentage fell under LOW_BATTERY) or 'charging'
    (status turned CHARGING); goals: [(t, target, status)] of move_base goals in the order
    sent, target a waypoint index or 'dock', status the goal's final actionlib status
    (None while it runs). The interrupted waypoint is the last waypoint goal sent before
    the low event; if move_base reported it SUCCEEDED (reached while the cancel was on its
    way) the cruise rightly resumes at the next one. Returns a dict per low event."""
    out = []
    for t_low, kind in events:
        if kind != "low":
            continue
        before = [(g, st) for t, g, st in goals if t <= t_low and g != "dock"]
        interrupted, status = before[-1] if before else (None, None)
        expected = interrupted
        if interrupted is not None and status == SUCCEEDED:
            expected = (interrupted + 1) % n_waypoints
        charged = [t for t, k in events if k == "charging" and t > t_low]
        t_charge = charged[0] if charged else None
        after = [g for t, g, _ in goals if t_charge is not None and t > t_charge and g != "dock"]
        resumed = after[0] if after else None
        out.append({"t_low": round(t_low, 1), "interrupted": interrupted, "expected": expected,
                    "charged_at": None if t_charge is None else round(t_charge, 1),
                    "resumed": resumed, "ok": t_charge is not None and resumed == expected})
    return out


def footprint_edge(length=0.72, width=0.62, spacing=0.05):
    """Points (N, 2) [m] along the footprint's outline in base_footprint."""
    hl, hw = length / 2.0, width / 2.0
    xs = np.linspace(-hl, hl, int(length / spacing) + 1)
    ys = np.linspace(-hw, hw, int(width / spacing) + 1)
    return np.vstack([np.column_stack([xs, np.full_like(xs, hw)]), np.column_stack([xs, np.full_like(xs, -hw)]),
                      np.column_stack([np.full_like(ys, hl), ys]), np.column_stack([np.full_like(ys, -hl), ys])])


def run(laps, speed, seed, box, adaptive, capacity_wh, min_charges, log, health_dir):
    from summit_nav_common.testing.roslaunch_session import RoslaunchSession, wait_for_sim_time_param
    waypoints, dock = load_route()
    battery_file = BATTERY
    tmp = None
    if capacity_wh is not None:
        with open(BATTERY) as f:
            battery = yaml.safe_load(f)
        battery["battery_capacity_wh"] = float(capacity_wh)
        tmp = tempfile.NamedTemporaryFile("w", suffix=".yaml", delete=False)
        yaml.safe_dump(battery, tmp)
        tmp.close()
        battery_file = tmp.name
    args = ["my_summit_navigation", "race_track.launch", f"laps:={laps}", f"speed:={speed}", f"seed:={seed}",
            f"adaptive:={'true' if adaptive else 'false'}", f"battery_file:={battery_file}",
            f"health_dir:={health_dir}"]
    try:
        with RoslaunchSession(args, log=log) as session:
            wait_for_sim_time_param(session)
            return watch(session, laps, speed, box, min_charges, waypoints, dock, health_dir)
    finally:
        if tmp is not None:
            os.unlink(tmp.name)


def watch(session, laps, speed, box, min_charges, waypoints, dock, health_dir):
    import rospy
    from geometry_msgs.msg import Pose2D
    from move_base_msgs.msg import MoveBaseActionGoal, MoveBaseActionResult
    from nav_msgs.msg import Odometry
    from sensor_msgs.msg import BatteryState
    from std_msgs.msg import String, UInt32

    from summit_nav_common.geometry import quaternion_to_yaw, transform_points
    from summit_xl_sim.srv import AddBox, RemoveBox
    from summit_xl_sim.world import World

    rospy.init_node("bench_race_track", anonymous=True, disable_signals=True)
    world = World.from_yaml(WORLD)
    edge = footprint_edge()
    lock = threading.Lock()
    st = {"pose": None, "t_sample": -math.inf, "least_clearance": math.inf, "where": None, "collisions": 0,
          "goals": [], "goal_ids": [], "final": {}, "results": [], "events": [], "pct": None, "status": None, "summary": None,
          "max_speed": 0.0}

    def on_truth(msg):
        p = msg.pose.pose
        pose = (p.position.x, p.position.y, quaternion_to_yaw(p.orientation))
        t = msg.header.stamp.to_sec()
        with lock:
            st["pose"] = pose
            st["max_speed"] = max(st["max_speed"], abs(msg.twist.twist.linear.x))
            if t - st["t_sample"] < TRUTH_PERIOD:
                return
            st["t_sample"] = t
        pts = transform_points(edge, pose)
        c = min(world.clearance(x, y) for x, y in pts)
        with lock:
            if c < st["least_clearance"]:
                st["least_clearance"], st["where"] = c, (round(pose[0], 2), round(pose[1], 2))

    def on_goal(msg):
        p = msg.goal.target_pose.pose.position
        target = match_goal((p.x, p.y), waypoints, dock)
        with lock:
            st["goals"].append((rospy.Time.now().to_sec(), target))
            st["goal_ids"].append(msg.goal_id.id)

    def on_result(msg):
        with lock:
            st["results"].append((rospy.Time.now().to_sec(), msg.status.status))
            st["final"][msg.status.goal_id.id] = msg.status.status

    def on_battery(msg):
        t = msg.header.stamp.to_sec() or rospy.Time.now().to_sec()
        with lock:
            if st["pct"] is not None and st["pct"] >= LOW_BATTERY > msg.percentage:
                st["events"].append((t, "low"))
            if msg.power_supply_status == CHARGING and st["status"] != CHARGING:
                st["events"].append((t, "charging"))
            st["pct"], st["status"] = msg.percentage, msg.power_supply_status

    def on_coll(msg):
        with lock:
            st["collisions"] = max(st["collisions"], msg.data)

    def on_summary(msg):
        with lock:
            st["summary"] = msg.data

    rospy.Subscriber("/base_pose_ground_truth", Odometry, on_truth, queue_size=20)
    rospy.Subscriber("/move_base/goal", MoveBaseActionGoal, on_goal, queue_size=10)
    rospy.Subscriber("/move_base/result", MoveBaseActionResult, on_result, queue_size=10)
    rospy.Subscriber("/battery_state", BatteryState, on_battery, queue_size=10)
    rospy.Subscriber("/collisions", UInt32, on_coll, queue_size=5)
    rospy.Subscriber("/auto_navigator/summary", String, on_summary, queue_size=1)
    rospy.wait_for_service("/summit_xl_sim/add_box", 120.0)
    add_box = rospy.ServiceProxy("/summit_xl_sim/add_box", AddBox)
    remove_box = rospy.ServiceProxy("/summit_xl_sim/remove_box", RemoveBox)
    box_state = {"dropped": None, "removed": None, "min_dist": math.inf, "goals_at_drop": None}
    box_xy = BOX_XY if box else None
    laps_seen = 0
    w0 = time.monotonic()
    wall_limit = WALL_LIMIT_PER_LAP * max(1, laps) / max(speed, 0.1) + 600.0
    while session.alive() and time.monotonic() - w0 < wall_limit:
        time.sleep(0.1)
        with lock:
            summary, pose, n_goals = st["summary"], st["pose"], len(st["goals"])
            wp_goals = [g for _, g in st["goals"] if g != "dock"]
        if summary is not None:
            break
        if pose is None or box_xy is None:
            continue
        # The lap: the number of times the first waypoint has been sent as a goal.
        laps_seen = sum(1 for g in wp_goals if g == 0)
        now = rospy.Time.now().to_sec()
        if box_state["dropped"] is None and laps_seen >= BOX_LAP \
                and math.hypot(pose[0] - box_xy[0], pose[1] - box_xy[1]) <= BOX_AHEAD:
            resp = add_box("narrow_box", Pose2D(box_xy[0], box_xy[1], 0.0),
                           BOX_SIZE, BOX_SIZE)
            if resp.success:
                box_state.update(dropped=round(now, 1), goals_at_drop=n_goals)
                print(f"box dropped at ({box_xy[0]:.2f}, {box_xy[1]:.2f})", flush=True)
        elif box_state["dropped"] is not None and box_state["removed"] is None:
            box_state["min_dist"] = min(box_state["min_dist"], math.hypot(pose[0] - box_xy[0], pose[1] - box_xy[1]))
            with lock:
                goal_ended = len(st["results"]) > box_state["goals_at_drop"]
            if goal_ended or now - box_state["dropped"] > BOX_FOR:
                remove_box("narrow_box")
                box_state["removed"] = round(now, 1)
    wall = time.monotonic() - w0
    sim_t = rospy.Time.now().to_sec()
    with lock:
        res = dict(st)
    summary = json.loads(res["summary"]) if res["summary"] else None
    health = None
    health_path = os.path.join(health_dir, "health.json")
    end = time.monotonic() + 60.0
    while summary is not None and time.monotonic() < end and not os.path.exists(health_path):
        time.sleep(0.5)
    if os.path.exists(health_path):
        with open(health_path) as f:
            health = json.load(f)
    goals = [(t, g, res["final"].get(gid)) for (t, g), gid in zip(res["goals"], res["goal_ids"])]
    battery = judge_battery(res["events"], goals, len(waypoints))
    n_wp = len(waypoints)
    skipped = summary.get("skipped", []) if summary else []
    reached = summary.get("reached") if summary else None
    accounted = (reached or 0) + len(skipped)
    dock_goals = sum(1 for _, g in res["goals"] if g == "dock")
    box_clear = BOX_SIZE / 2 + HALF_WIDTH - CORNER_SLACK    # [m] robot centre to box centre, at least
    box_ok = box_xy is None or (box_state["dropped"] is not None and box_state["min_dist"] > box_clear)
    # Charging stops on the way: the robot starts docked, and the charger it leaves is not one.
    t_first_goal = res["goals"][0][0] if res["goals"] else math.inf
    charges = sum(1 for t, k in res["events"] if k == "charging" and t > t_first_goal)
    ok = (summary is not None and accounted == laps * n_wp and res["collisions"] == 0
          and all(b["ok"] for b in battery) and all(s.get("reason") for s in skipped) and box_ok
          and charges >= min_charges)
    return {"ok": bool(ok), "laps": laps, "speed": speed, "waypoints_per_lap": n_wp,
            "summary": summary, "reached": reached, "skipped": skipped, "accounted": accounted,
            "collisions": int(res["collisions"]), "low_battery_events": battery,
            "charges": charges, "min_charges": min_charges, "dock_goals": dock_goals,
            "least_clearance_m": round(res["least_clearance"], 3), "least_clearance_at": res["where"],
            "max_speed_mps": round(res["max_speed"], 2),
            "box": None if box_xy is None else {"xy": box_xy, "dropped_s": box_state["dropped"],
                                                "removed_s": box_state["removed"],
                                                "min_centre_dist_m": round(box_state["min_dist"], 2),
                                                "needed_m": round(box_clear, 2), "ok": bool(box_ok)},
            "health": health, "sim_s": round(sim_t, 1), "wall_s": round(wall, 1)}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--laps", type=int, default=10)
    ap.add_argument("--speed", type=float, default=1.0, help="simulated seconds per wall second")
    ap.add_argument("--seed", type=int, default=0, help="the simulator's noise seed")
    ap.add_argument("--box", action="store_true", help="drop a box on the narrow section on lap 2")
    ap.add_argument("--adaptive", action="store_true", help="run the adaptive parameters node")
    ap.add_argument("--capacity-wh", type=float, help="the battery's capacity [Wh] (race track default otherwise)")
    ap.add_argument("--min-charges", type=int, default=0, help="charging stops the run must have, at least")
    ap.add_argument("--json", help="write the result here")
    args = ap.parse_args(argv)
    out_dir = os.path.join(WS, "output", "race_track")
    os.makedirs(out_dir, exist_ok=True)
    tag = f"laps{args.laps}{'_adaptive' if args.adaptive else ''}{'_box' if args.box else ''}"
    health_dir = os.path.join(out_dir, tag)
    os.makedirs(health_dir, exist_ok=True)
    for name in ("health.json", "laps.png", "battery_speed.png"):   # an earlier run's report must not be read
        if os.path.exists(os.path.join(health_dir, name)):
            os.remove(os.path.join(health_dir, name))
    res = run(args.laps, args.speed, args.seed, args.box, args.adaptive, args.capacity_wh, args.min_charges,
              os.path.join(out_dir, tag + ".log"), health_dir)
    res["adaptive"] = bool(args.adaptive)
    print(json.dumps(res), flush=True)
    if args.json:
        from summit_nav_common.files import write_atomic
        write_atomic(args.json, json.dumps(res, indent=1))
    return 0 if res["ok"] else 1


if __name__ == "__main__":
    sys.exit(main())
