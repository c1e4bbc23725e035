#!/usr/bin/python3
"""`make demo`: the course project, headless, with progress lines, a table and pictures.

Today it runs course step 1 end to end: the simulator and the tour driver take the
Summit XL through every room of the built-in building (what the student does with the
keyboard) while slam_gmapping maps it; map_saver saves the map. Pictures: the world with
the driven trajectory and one laser scan (output/demo_tour.png) and the SLAM map judged
against the true walls (output/demo_slam_map.png). Then course step 3 on the committed
map: amcl + move_base (simulator restarted at the mapping start pose) drive the robot
through actionlib to the three spots of my_summit_localization's spots.yaml, with a
picture of the plan and the driven path over the global costmap for each
(output/demo_nav_<label>.png). Still to come (issue 6): recording the spots with
/save_spot on the fresh map and /get_coordinates.

    make demo            headless
    make demo GUI=1      the same with rviz open (needs a display)
"""
import argparse
import json
import math
import os
import subprocess
import sys
import time

import cv2
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from roslaunch_session import RoslaunchSession, wait_for, wait_for_sim_time_param  # noqa: E402

WS = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
OUT = os.path.join(WS, "output")
# A map below these (share of mapped cells on true walls / of seen walls mapped) is reported
# as poor in the table (the figures are 0.95 / 0.90).
MAP_PRECISION_OK = 0.90
MAP_RECALL_OK = 0.85
MAPPING_SPEED = 4.0  # simulated seconds per wall second while mapping (SLAM needs ~0.12 CPU s per sim s)
ROOMS = [  # (name, xmin, ymin, xmax, ymax) of the built-in building [m]
    ("main hall", 0, 0, 12, 14), ("room 1", 12, 7, 16, 14),
    ("room 2", 16, 7, 20, 14), ("fetch room", 12, 0, 20, 7)]


def room_of(x, y):
    """Name of the room containing (x, y), or None."""
    for name, x0, y0, x1, y1 in ROOMS:
        if x0 <= x < x1 and y0 <= y < y1:
            return name
    return None


class Progress:
    """Prints one line per event with simulated and wall time (since the demo started)."""

    def __init__(self, wall0=None):
        self.wall0 = time.monotonic() if wall0 is None else wall0

    def line(self, sim_t, text):
        print(f"[sim {sim_t:7.1f} s | wall {time.monotonic() - self.wall0:6.1f} s] {text}", flush=True)


def draw_world_picture(world, trajectory, scan_pose, scan_xy, path, scale=3):
    """The world map with the trajectory (blue), a scan (red) and the robot (green)."""
    base = np.where(world.grid.data == 100, 0, np.where(world.grid.data == 0, 255, 205)).astype(np.uint8)
    img = cv2.cvtColor(base[::-1], cv2.COLOR_GRAY2BGR)
    img = cv2.resize(img, None, fx=scale, fy=scale, interpolation=cv2.INTER_NEAREST)
    h = img.shape[0]

    def px(x, y):
        gx, gy = world.to_grid(x, y)
        return int(round(gx * scale)), int(round(h - gy * scale))

    if len(trajectory) > 1:
        pts = np.array([px(x, y) for x, y in trajectory], np.int32)
        cv2.polylines(img, [pts], False, (200, 90, 20), 2, cv2.LINE_AA)
    for x, y in scan_xy:
        cv2.circle(img, px(x, y), 2, (0, 0, 230), -1, cv2.LINE_AA)
    if scan_pose is not None:
        x, y, yaw = scan_pose
        c, s = math.cos(yaw), math.sin(yaw)
        corners = [(x + c * a - s * b, y + s * a + c * b)
                   for a, b in ((0.36, 0.31), (-0.36, 0.31), (-0.36, -0.31), (0.36, -0.31))]
        cv2.polylines(img, [np.array([px(*p) for p in corners], np.int32)], True, (0, 160, 0), 2, cv2.LINE_AA)
        cv2.line(img, px(x, y), px(x + 0.5 * c, y + 0.5 * s), (0, 160, 0), 2, cv2.LINE_AA)
    cv2.putText(img, "Summit XL tour: trajectory (blue), one laser scan (red), robot (green)",
                (10, 22), cv2.FONT_HERSHEY_SIMPLEX, 0.55, (40, 40, 40), 1, cv2.LINE_AA)
    tmp = path + ".tmp.png"
    cv2.imwrite(tmp, img)
    os.replace(tmp, path)


def step_mapping(progress, gui):
    """Step 1: simulator + tour driver + slam_gmapping, then map_saver.

    Returns result rows for the table, and draws the tour picture (world, trajectory,
    one scan) and the SLAM map judged against the true walls.
    """
    import rospy
    import yaml
    from rospy.numpy_msg import numpy_msg
    from sensor_msgs.msg import LaserScan
    from std_msgs.msg import UInt32

    from my_summit_mapping.slam_config import SlamConfig
    from summit_xl_sim.world import World
    sys.path.insert(0, os.path.join(WS, "src", "my_summit_mapping", "scripts"))
    from bench_slam_sim import TourRecorder, write_png  # shared with the mapping rostest

    world = World.from_yaml(os.path.join(WS, "src", "summit_xl_sim", "worlds", "course_building.yaml"))
    with open(os.path.join(WS, "src", "my_summit_mapping", "config", "gmapping_params.yaml")) as f:
        slam_cfg = SlamConfig.from_dict(yaml.safe_load(f))
    log = os.path.join(OUT, "demo_mapping_launch.log")
    args = ["my_summit_mapping", "gmapping.launch", "driver:=tour", f"speed:={MAPPING_SPEED}",
            f"gui:={'true' if gui else 'false'}"]
    rows = []
    with RoslaunchSession(args, log=log) as session:
        wait_for_sim_time_param(session)
        rospy.init_node("demo", anonymous=True, disable_signals=True)
        recorder = TourRecorder()
        state = {"coll": 0, "scan": None, "scan_pose": None}

        def on_scan(msg):
            with recorder.lock:
                pose = tuple(recorder.truth[-1][1:]) if recorder.truth else None
            # Keep the scan taken nearest the fetch room's centre: it shows the table legs.
            if pose is not None and (state["scan_pose"] is None or
                                     math.hypot(pose[0] - 16.0, pose[1] - 3.5)
                                     < math.hypot(state["scan_pose"][0] - 16.0, state["scan_pose"][1] - 3.5)):
                state["scan"], state["scan_pose"] = np.array(msg.ranges), pose

        rospy.Subscriber("/hokuyo_base/scan", numpy_msg(LaserScan), on_scan, queue_size=2)
        rospy.Subscriber("/collisions", UInt32, lambda m: state.update(coll=m.data), queue_size=1)
        wait_for(lambda: bool(recorder.truth), 60, "the simulator's ground truth", session)
        x0, y0 = recorder.truth[-1][1:3]
        progress.line(rospy.Time.now().to_sec(), f"simulator up at {MAPPING_SPEED:.0f}x real time, slam_gmapping "
                      f"({slam_cfg.particles} particles) mapping, tour driver starting at ({x0:.1f}, {y0:.1f})")
        room, t_start, wall_start = None, rospy.Time.now().to_sec(), time.monotonic()
        while recorder.done_time is None:
            if not session.alive():
                raise RuntimeError(f"the launch ended early (see {log})")
            with recorder.lock:
                pose = recorder.truth[-1][1:]
                maps = recorder.map_count
            here = room_of(pose[0], pose[1])
            if here and here != room:
                room = here
                progress.line(rospy.Time.now().to_sec(), f"entered the {here} ({maps} maps published so far)")
            if time.monotonic() - wall_start > 600:
                raise RuntimeError("the tour did not finish within 600 s of wall time")
            time.sleep(0.05)
        sim_t = rospy.Time.now().to_sec() - t_start
        progress.line(rospy.Time.now().to_sec(), f"tour finished, {state['coll']} collisions; waiting for the final map")
        problem = recorder.wait_done_and_final_map(120.0, session.alive)
        if problem:
            raise RuntimeError(f"mapping: {problem} (see {log})")
        wall_t = time.monotonic() - wall_start
        result = recorder.evaluate(world, slam_cfg.maxUrange)
        progress.line(rospy.Time.now().to_sec(), f"map judged against the true walls: ATE {result['ate_m']:.3f} m, "
                      f"precision {result['precision']:.3f}, recall {result['recall']:.3f}")
        t0 = time.monotonic()
        base = os.path.join(OUT, "demo_map")
        saver = subprocess.run(["rosrun", "my_summit_mapping", "map_saver", "-f", base], env=session.env,
                               stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=120)
        if saver.returncode != 0:
            raise RuntimeError(f"map_saver failed: {saver.stdout[-1500:]}")
        progress.line(rospy.Time.now().to_sec(), f"map saved with map_saver: {os.path.relpath(base, WS)}.pgm/.yaml")
        save_t = time.monotonic() - t0
        last_sim = rospy.Time.now().to_sec()
        with recorder.lock:
            traj = [(x, y) for _, x, y, _ in recorder.truth]
    pose, ranges = state["scan_pose"], state["scan"]
    scan_xy = []
    if ranges is not None:
        lx, ly = pose[0] + 0.25 * math.cos(pose[2]), pose[1] + 0.25 * math.sin(pose[2])
        ang = np.linspace(-2.356194490192345, 2.356194490192345, len(ranges)) + pose[2]
        ok = np.isfinite(ranges)
        scan_xy = np.column_stack([lx + ranges[ok] * np.cos(ang[ok]), ly + ranges[ok] * np.sin(ang[ok])])
    draw_world_picture(world, traj, pose, scan_xy, os.path.join(OUT, "demo_tour.png"))
    write_png(result, os.path.join(OUT, "demo_slam_map.png"), world)
    progress.line(last_sim, "pictures written: output/demo_tour.png, output/demo_slam_map.png")
    length = float(np.sum(np.hypot(*np.diff(np.array(traj), axis=0).T))) if len(traj) > 1 else 0.0
    rows.append({"step": "1. map the building (sim + tour + slam_gmapping)",
                 "result": ("COLLISION" if state["coll"] else
                            "ok" if result["precision"] >= MAP_PRECISION_OK and result["recall"] >= MAP_RECALL_OK
                            else "POOR MAP"), "sim_s": sim_t, "wall_s": wall_t,
                 "detail": f"{length:.1f} m driven, {state['coll']} collisions; SLAM ATE {result['ate_m']:.3f} m, "
                           f"map precision {result['precision']:.3f} / recall {result['recall']:.3f}"})
    rows.append({"step": "1. save the map (map_saver)", "result": "ok", "sim_s": 0.0, "wall_s": save_t,
                 "detail": f"{os.path.relpath(base, WS)}.pgm + .yaml"})
    return rows


NAV_SPEED = 3.0       # simulated seconds per wall second while navigating
SPOT_ORDER = ("table", "room", "turtle")  # crosses rooms: fetch room table, its centre, the poster
GOAL_TIMEOUT = 240.0  # [s] of wall time per spot


def draw_costmap_picture(costmap_msg, plan_xy, driven_xy, spot, path, title, scale=3):
    """The global costmap (grey levels, lethal black, inflation shaded), the plan (blue)
    and the driven path (green) to a spot (red arrow), in the map frame."""
    info = costmap_msg.info
    data = np.asarray(costmap_msg.data, np.int16).reshape(info.height, info.width)
    base = np.where(data < 0, 205, 255 - np.clip(data, 0, 100) * 2.2).astype(np.uint8)
    img = cv2.resize(cv2.cvtColor(base[::-1], cv2.COLOR_GRAY2BGR), None, fx=scale, fy=scale,
                     interpolation=cv2.INTER_NEAREST)
    h = img.shape[0]
    ox, oy, res = info.origin.position.x, info.origin.position.y, info.resolution

    def px(x, y):
        return int(round((x - ox) / res * scale)), int(round(h - (y - oy) / res * scale))

    for pts, colour in ((plan_xy, (220, 120, 0)), (driven_xy, (0, 170, 0))):
        if len(pts) > 1:
            cv2.polylines(img, [np.array([px(x, y) for x, y in pts], np.int32)], False, colour, 2, cv2.LINE_AA)
    x, y, yaw = spot
    cv2.arrowedLine(img, px(x, y), px(x + 0.6 * math.cos(yaw), y + 0.6 * math.sin(yaw)), (0, 0, 230), 2,
                    cv2.LINE_AA, tipLength=0.35)
    cv2.putText(img, title, (10, 22), cv2.FONT_HERSHEY_SIMPLEX, 0.55, (30, 30, 30), 1, cv2.LINE_AA)
    tmp = path + ".tmp.png"
    cv2.imwrite(tmp, img)
    os.replace(tmp, path)


def step_navigate(progress, gui):
    """Step 3 (and 4's goals): move_base + amcl on the committed map, the robot sent
    through actionlib to the course's three spots of config/spots.yaml, ground truth
    checked in the map frame; a picture of plan and driven path over the costmap each."""
    import actionlib
    import rospy
    from move_base_msgs.msg import MoveBaseAction, MoveBaseGoal
    from nav_msgs.msg import OccupancyGrid, Odometry, Path
    from rospy.numpy_msg import numpy_msg
    from std_msgs.msg import UInt32

    from my_summit_localization.spots import load_spots
    sys.path.insert(0, os.path.join(WS, "src", "my_summit_localization", "test"))
    from loctest_util import register_map  # the map frame's pose in the world, from the maps

    spots_file = os.path.join(WS, "src", "my_summit_localization", "config", "spots.yaml")
    map_file = os.path.join(WS, "src", "my_summit_mapping", "maps", "my_map.yaml")
    world_file = os.path.join(WS, "src", "summit_xl_sim", "worlds", "course_building.yaml")
    _, spots = load_spots(spots_file)
    m_in_w = register_map(map_file, world_file, (2.0, 7.0, 0.0))
    c, s_ = math.cos(-m_in_w[2]), math.sin(-m_in_w[2])

    def to_map(x, y, yaw):
        dx, dy = x - m_in_w[0], y - m_in_w[1]
        return c * dx - s_ * dy, s_ * dx + c * dy, yaw - m_in_w[2]

    log = os.path.join(OUT, "demo_navigation_launch.log")
    args = ["my_summit_path_planning", "move_base.launch", "sim:=true", f"speed:={NAV_SPEED}",
            f"gui:={'true' if gui else 'false'}"]
    rows = []
    with RoslaunchSession(args, log=log) as session:
        wait_for_sim_time_param(session)
        rospy.init_node("demo_navigation", anonymous=True, disable_signals=True)
        state = {"truth": None, "plan": None, "costmap": None, "coll": 0}
        rospy.Subscriber("/base_pose_ground_truth", Odometry, lambda m: state.update(truth=m), queue_size=10)
        rospy.Subscriber("/move_base/NavfnROS/plan", Path, lambda m: state.update(plan=m), queue_size=1)
        rospy.Subscriber("/move_base/global_costmap/costmap", numpy_msg(OccupancyGrid),
                         lambda m: state.update(costmap=m), queue_size=1, buff_size=2 ** 24)
        rospy.Subscriber("/collisions", UInt32, lambda m: state.update(coll=m.data), queue_size=1)
        client = actionlib.SimpleActionClient("move_base", MoveBaseAction)
        wait_for(lambda: client.wait_for_server(rospy.Duration(0.5)), 120, "the move_base action server", session)
        wait_for(lambda: state["truth"] is not None, 60, "ground truth", session)
        progress.line(rospy.Time.now().to_sec(), f"amcl + move_base up on the committed map at {NAV_SPEED:.0f}x; "
                      f"spots from {os.path.relpath(spots_file, WS)}")

        def truth_map():
            p = state["truth"].pose.pose
            q = p.orientation
            return to_map(p.position.x, p.position.y,
                          math.atan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y * q.y + q.z * q.z)))

        for label in SPOT_ORDER:
            spot = spots[label]
            goal = MoveBaseGoal()
            goal.target_pose.header.frame_id = "map"
            goal.target_pose.header.stamp = rospy.Time.now()
            goal.target_pose.pose.position.x, goal.target_pose.pose.position.y = spot.x, spot.y
            goal.target_pose.pose.orientation.z = math.sin(spot.yaw / 2.0)
            goal.target_pose.pose.orientation.w = math.cos(spot.yaw / 2.0)
            state["plan"] = None
            driven = []
            t0, w0 = rospy.Time.now().to_sec(), time.monotonic()
            client.send_goal(goal)
            progress.line(t0, f"goal '{label}' ({spot.x:.2f}, {spot.y:.2f}, {math.degrees(spot.yaw):.0f} deg) sent")
            first_plan = None
            while not client.wait_for_result(rospy.Duration(0.1)):
                if first_plan is None and state["plan"] is not None and state["plan"].poses:
                    first_plan = [(p.pose.position.x, p.pose.position.y) for p in state["plan"].poses]
                driven.append(truth_map()[:2])
                if not session.alive() or time.monotonic() - w0 > GOAL_TIMEOUT:
                    client.cancel_goal()
                    break
            status, text = client.get_state(), client.get_goal_status_text()
            x, y, yaw = truth_map()
            err = math.hypot(x - spot.x, y - spot.y)
            yaw_err = abs((yaw - spot.yaw + math.pi) % (2 * math.pi) - math.pi)
            ok = status == actionlib.GoalStatus.SUCCEEDED and err <= 0.3 and yaw_err <= 0.3
            sim_t, wall_t = rospy.Time.now().to_sec() - t0, time.monotonic() - w0
            progress.line(rospy.Time.now().to_sec(), f"'{label}': {actionlib.GoalStatus.to_string(status)} "
                          f"({text or 'no text'}); ground truth {err:.3f} m, {math.degrees(yaw_err):.1f} deg from the spot")
            picture = os.path.join(OUT, f"demo_nav_{label}.png")
            if state["costmap"] is not None:
                draw_costmap_picture(state["costmap"], first_plan or [], driven, (spot.x, spot.y, spot.yaw), picture,
                                     f"to '{label}': plan (blue), driven (green), global costmap")
            rows.append({"step": f"3. navigate to '{label}' (move_base)", "result": "ok" if ok else "FAILED",
                         "sim_s": sim_t, "wall_s": wall_t,
                         "detail": f"pose error {err:.3f} m / {math.degrees(yaw_err):.1f} deg, "
                                   f"{state['coll']} collisions so far"})
    return rows


STEPS = [step_mapping, step_navigate]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--gui", action="store_true", help="open rviz (needs a display)")
    names = [f.__name__[len("step_"):] for f in STEPS]
    ap.add_argument("--only", choices=names, action="append", help="run only these steps (for development)")
    ap.add_argument("--child", choices=names, help=argparse.SUPPRESS)
    ap.add_argument("--rows", help=argparse.SUPPRESS)
    ap.add_argument("--wall0", type=float, help=argparse.SUPPRESS)
    args = ap.parse_args()
    os.makedirs(OUT, exist_ok=True)
    if args.child:  # one step, in its own process: rospy binds a process to one master
        progress = Progress(args.wall0)
        rows = next(f for f in STEPS if f.__name__ == "step_" + args.child)(progress, args.gui)
        with open(args.rows, "w") as f:
            json.dump(rows, f)
        return 0
    wall0 = time.monotonic()
    rows = []
    for name in names:
        if args.only and name not in args.only:
            continue
        rows_file = os.path.join(OUT, f".demo_rows_{name}.json")
        cmd = [sys.executable, os.path.abspath(__file__), "--child", name, "--rows", rows_file,
               "--wall0", str(wall0)] + (["--gui"] if args.gui else [])
        if os.path.exists(rows_file):
            os.remove(rows_file)
        r = subprocess.run(cmd)
        if r.returncode != 0 or not os.path.exists(rows_file):
            rows.append({"step": name, "result": "FAILED", "sim_s": 0.0, "wall_s": 0.0,
                         "detail": f"the step's process exited with {r.returncode} (see output/ logs)"})
            break
        with open(rows_file) as f:
            rows.extend(json.load(f))
        os.remove(rows_file)
    print("\n| step | result | sim time [s] | wall time [s] | detail |\n| --- | --- | --- | --- | --- |")
    for r in rows:
        print(f"| {r['step']} | {r['result']} | {r['sim_s']:.1f} | {r['wall_s']:.1f} | {r['detail']} |")
    print(f"\ntotal wall time {time.monotonic() - wall0:.0f} s; pictures in output/")
    return 0 if all(r["result"] == "ok" for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
