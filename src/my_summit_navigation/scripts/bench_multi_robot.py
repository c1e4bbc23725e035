#!/usr/bin/python3
"""bench_multi_robot: the multi-robot lesson's figures, printed as one JSON summary.

    rosrun my_summit_navigation bench_multi_robot.py [--runs 3] [--max-robots 12] [--window 30]
    (from the workspace: source devel/setup.bash; /usr/bin/python3 .../bench_multi_robot.py)

(a) lesson: the lesson's rostests (multi_robot_lesson_amcl.test, _fake.test) --runs times
    each; per run and robot: move_base's outcome, final pose error by ground truth, largest
    localization error (amcl_pose against the truth), collisions, simulated time to the
    result; the wall time of the run; medians over the runs.
(b) scale: n = 1, 2, ... robots on willow-full, each with amcl + move_base and a goal
    across the lesson's room and the rooms and corridors around it (AREA: 26 spawn points,
    so up to 13 robots), the simulator at speed 1; over --window seconds of wall
    time while they drive: the achieved real-time factor (/clock advance / wall time) and
    the CPU of every robot's amcl + move_base (cores, from /proc through psutil) and of the
    simulator. The answer is the largest n whose factor is >= --rtf (default 0.97:
    the simulator holds 1.0 when it keeps up; its own sleep jitter costs ~1%).
Not a test: it measures and reports. Each launch gets its own ROS master and is stopped,
with everything below it, at the end (summit_nav_common.testing.roslaunch_session).
"""
import argparse
import glob
import json
import math
import os
import re
import statistics
import sys
import tempfile
import time

import cv2
import numpy as np
import psutil
import rospkg
from summit_nav_common.map_io import load_map
from summit_nav_common.ros.action_client import SimpleActionClient
from summit_nav_common.testing.roslaunch_session import (RoslaunchSession, run_bounded, wait_for,
                                                         wait_for_sim_time_param)

from my_summit_navigation.multi_robot import robots_param

PKG = rospkg.RosPack().get_path("my_summit_navigation")
WS = os.path.normpath(os.path.join(PKG, "..", ".."))

MAP_YAML = os.path.join(PKG, "maps", "willow-full.yaml")
LINE = re.compile(r"MULTI_ROBOT (.*?) text=")
FIELD = re.compile(r"(\w+)=(\S+)")
# [m] x0, x1, y0, y1: the lesson's room (x 1.5-15, y 11-19.8) and what lies around it up to
# y 25 and x 19: where robots spawn (the south rows) and drive to (the north rows). The
# room alone has 9 points: 4 robots, which still ran at real time.
AREA = (1.5, 19.0, 5.0, 25.0)
SPACING = 1.5                      # [m] between spawn/goal grid points
CLEARANCE = 0.6                    # [m] from any wall for a grid point
RUN_TIMEOUT = 900                  # [s] wall per rostest run


# -- (a) the lesson ----------------------------------------------------------------------
def lesson_run(localization, tmp):
    env = dict(os.environ, ROS_HOME=tmp, ROS_LOG_DIR=os.path.join(tmp, "log"))
    w0 = time.monotonic()
    rc, out = run_bounded(["rostest", "my_summit_navigation", f"multi_robot_lesson_{localization}.test"],
                          env, RUN_TIMEOUT)
    wall = time.monotonic() - w0
    robots = {}
    for xml in glob.glob(os.path.join(tmp, "test_results", "my_summit_navigation", "rosunit-*.xml")):
        for m in LINE.finditer(open(xml, errors="replace").read()):
            kv = dict(FIELD.findall(m.group(1)))
            if "robot" not in kv:
                print(f"lesson {localization}: unparsable MULTI_ROBOT line: {m.group(0)[:300]!r}", file=sys.stderr)
                continue
            fields = {}
            for k, v in kv.items():
                try:
                    fields[k] = v if k in ("robot", "state") else float(v)
                except ValueError:
                    print(f"lesson {localization}: {k}={v!r} is not a number in {m.group(0)[:300]!r}",
                          file=sys.stderr)
            robots[fields.pop("robot")] = fields
    return {"passed": rc == 0 and "RESULT: SUCCESS" in out, "wall_s": round(wall, 1), "robots": robots}


def lesson(runs):
    summary = {}
    for loc in ("amcl", "fake"):
        results = []
        for i in range(runs):
            with tempfile.TemporaryDirectory(prefix="bench_mr_") as tmp:
                r = lesson_run(loc, tmp)
            print(f"lesson {loc} run {i + 1}/{runs}: {'passed' if r['passed'] else 'FAILED'} in {r['wall_s']} s "
                  f"wall; " + "; ".join(f"{n} {v.get('state')} {v.get('xy_error_m')} m, "
                                        f"{v.get('collisions')} collisions" for n, v in r["robots"].items()),
                  file=sys.stderr, flush=True)
            results.append(r)
        rows = [v for r in results for v in r["robots"].values()]

        def med(key):
            vals = [v[key] for v in rows if key in v and math.isfinite(v[key])]
            return round(statistics.median(vals), 3) if vals else None
        summary[loc] = {
            "runs": runs, "runs_passed": sum(r["passed"] for r in results),
            "goals_reached": sum(v.get("state") == "SUCCEEDED" for v in rows), "goals": len(rows),
            "collisions": int(sum(v.get("collisions", 0) for v in rows)),
            "median_xy_error_m": med("xy_error_m"), "median_yaw_error_rad": med("yaw_error_rad"),
            "max_xy_error_m": round(max((v.get("xy_error_m", math.inf) for v in rows), default=math.nan), 3),
            "median_loc_error_max_m": med("loc_error_max_m"),
            "median_time_to_goal_sim_s": med("result_sim_s"),
            "median_run_wall_s": round(statistics.median(r["wall_s"] for r in results), 1),
            "runs_detail": results}
    return summary


# -- (b) scale ---------------------------------------------------------------------------
def grid_points():
    """Free points (x, y) [m] of AREA with CLEARANCE from walls, SPACING apart, south to north."""
    m = load_map(MAP_YAML)
    res = m.resolution
    ox, oy = m.origin[0], m.origin[1]
    dist = cv2.distanceTransform((m.data == 0).astype(np.uint8), cv2.DIST_L2, 5) * res
    pts = []
    for y in np.arange(AREA[2], AREA[3], SPACING):
        for x in np.arange(AREA[0], AREA[1], SPACING):
            r, c = int((y - oy) / res), int((x - ox) / res)  # rows bottom-up, as in the grid
            if dist[r, c] >= CLEARANCE:
                pts.append((round(float(x), 2), round(float(y), 2)))
    return pts


def scale_launch(n, starts):
    """Launch XML of the simulator, one map_server and n robots (amcl + move_base)."""
    robots = [(f"robot_{k}", x, y, 0.0) for k, (x, y) in enumerate(starts[:n])]
    groups = "\n".join(
        f"""  <group ns="{name}">
    <include file="$(find my_summit_navigation)/launch/robot_navigation.launch">
      <arg name="robot" value="{name}"/>
      <arg name="initial_pose_x" value="{x}"/> <arg name="initial_pose_y" value="{y}"/>
      <arg name="initial_pose_a" value="0.0"/> <arg name="amcl_seed" value="{k}"/>
    </include>
  </group>""" for k, (name, x, y, _) in enumerate(robots))
    return f"""<launch>
  <include file="$(find summit_xl_sim)/launch/sim.launch">
    <arg name="world" value="{MAP_YAML}"/>
    <arg name="robots" value="{robots_param(robots)}"/>
  </include>
  <include file="$(find my_summit_mapping)/launch/provide_map.launch">
    <arg name="map_file" value="{MAP_YAML}"/>
  </include>
{groups}
</launch>
"""


def procs_by_role(session):
    """{role: [psutil.Process]} of the launch's nodes: 'sim', 'robot_k', 'other'."""
    roles = {}
    for p in psutil.Process(session.proc.pid).children(recursive=True):
        try:
            cmd = " ".join(p.cmdline())
        except psutil.NoSuchProcess:
            continue
        try:
            ns = p.environ().get("ROS_NAMESPACE", "")   # roslaunch puts a group's nodes there
        except (psutil.NoSuchProcess, psutil.AccessDenied):
            ns = ""
        m = re.match(r"^/?(robot_\d+)/?$", ns)
        role = "sim" if "__name:=summit_xl_sim" in cmd else (m.group(1) if m else "other")
        roles.setdefault(role, []).append(p)
    return roles


def cpu_seconds(procs):
    total = 0.0
    for p in procs:
        try:
            t = p.cpu_times()
            total += t.user + t.system
        except psutil.NoSuchProcess:
            pass
    return total


def scale_run(n, points, window, tmp):
    import actionlib
    import rospy
    from move_base_msgs.msg import MoveBaseAction
    from my_summit_localization.spots import Spot
    from my_summit_navigation.goals import move_base_goal

    starts, goals = points[:n], points[len(points) - n:][::-1]
    path = os.path.join(tmp, f"scale_{n}.launch")
    with open(path, "w") as f:
        f.write(scale_launch(n, starts))
    with RoslaunchSession([path], log=os.path.join(tmp, f"scale_{n}.log")) as s:
        wait_for_sim_time_param(s)
        rospy.init_node("bench_multi_robot", anonymous=True, disable_signals=True)
        clients = [SimpleActionClient(f"/robot_{k}/move_base", MoveBaseAction) for k in range(n)]
        wait_for(lambda: all(c.wait_for_server(rospy.Duration(0.1)) for c in clients), 180,
                 f"{n} move_base servers", s)
        rospy.sleep(2.0)
        for k, c in enumerate(clients):
            gx, gy = goals[k]
            c.send_goal(move_base_goal(Spot.from_xy_yaw(gx, gy, 0.0), "map", rospy.Time.now()))
        roles = procs_by_role(s)
        time.sleep(2.0)  # past the goal's first plan
        c0 = {r: cpu_seconds(p) for r, p in roles.items()}
        t0, w0 = rospy.Time.now().to_sec(), time.monotonic()
        time.sleep(window)
        t1, w1 = rospy.Time.now().to_sec(), time.monotonic()
        c1 = {r: cpu_seconds(p) for r, p in roles.items()}
        wall = w1 - w0
        cores = {r: (c1[r] - c0[r]) / wall for r in roles}
        done = sum(c.get_state() == 3 for c in clients)
        for c in clients:
            c.cancel_all_goals()
    per_robot = [cores[f"robot_{k}"] for k in range(n) if f"robot_{k}" in cores]
    return {"robots": n, "rtf": round((t1 - t0) / wall, 3), "window_wall_s": round(wall, 1),
            "cpu_cores_per_robot_median": round(statistics.median(per_robot), 3) if per_robot else None,
            "cpu_cores_sim": round(cores.get("sim", 0.0), 3), "cpu_cores_other": round(cores.get("other", 0.0), 3),
            "goals_reached_in_window": done}


def scale(max_robots, window, rtf_min):
    points = grid_points()
    rows = []
    if True:
        for n in range(1, min(max_robots, len(points) // 2) + 1):
            # one process per step: rospy binds to one master per process
            rc, out = run_bounded([sys.executable, os.path.abspath(__file__), "--scale-one", str(n),
                                   "--window", str(window)], dict(os.environ), RUN_TIMEOUT)
            try:
                row = json.loads(out.strip().splitlines()[-1])
            except (ValueError, IndexError):
                row = {"robots": n, "rtf": 0.0, "error": out[-2000:]}
            print(f"scale: {n} robots: real-time factor {row['rtf']}, {row.get('cpu_cores_per_robot_median')} "
                  f"cores per robot, simulator {row.get('cpu_cores_sim')} cores", file=sys.stderr, flush=True)
            rows.append(row)
            if row["rtf"] < rtf_min:
                break
    ok = [r["robots"] for r in rows if r["rtf"] >= rtf_min]
    return {"max_robots_at_real_time": max(ok) if ok else 0, "rtf_threshold": rtf_min,
            "cpu_count": psutil.cpu_count(), "load_avg_at_start": [round(v, 2) for v in os.getloadavg()],
            "rows": rows}


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--runs", type=int, default=3, help="runs of each lesson rostest (default %(default)s)")
    p.add_argument("--max-robots", type=int, default=12, help="scale: stop there (default %(default)s)")
    p.add_argument("--window", type=float, default=30.0, help="[s] wall: scale measurement window")
    p.add_argument("--rtf", type=float, default=0.97, help="real-time factor that counts as real time")
    p.add_argument("--skip-lesson", action="store_true")
    p.add_argument("--skip-scale", action="store_true")
    p.add_argument("--scale-one", type=int, default=0, help=argparse.SUPPRESS)
    a = p.parse_args()
    if a.scale_one:
        with tempfile.TemporaryDirectory(prefix="bench_mr_scale_") as tmp:
            print(json.dumps(scale_run(a.scale_one, grid_points(), a.window, tmp)), flush=True)
        return
    out = {}
    if not a.skip_lesson:
        out["lesson"] = lesson(a.runs)
    if not a.skip_scale:
        out["scale"] = scale(a.max_robots, a.window, a.rtf)
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
