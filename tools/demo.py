#!/usr/bin/python3
"""`make demo`: the course project, headless, with progress lines, a table and pictures.

Today it runs the part that exists end to end: the simulator and the tour driver taking
the Summit XL through every room of the built-in building (what the student does with
the keyboard in the course's first step), and draws the world with the driven trajectory
and one laser scan into output/demo_tour.png. Later steps (mapping, localization,
navigation) append to STEPS.

    make demo            headless
    make demo GUI=1      the same with rviz open (needs a display)
"""
import argparse
import math
import os
import sys
import threading
import time

import cv2
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from roslaunch_session import RoslaunchSession, wait_for  # noqa: E402

WS = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
OUT = os.path.join(WS, "output")
SIM_SPEED = 10.0  # simulated seconds per wall second for the headless demo
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
    """Prints one line per event with simulated and wall time."""

    def __init__(self):
        self.wall0 = time.monotonic()

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


def step_tour(progress, gui):
    """Step 0: simulator + tour driver; returns a result row for the table."""
    import rospy
    from nav_msgs.msg import Odometry
    from rospy.numpy_msg import numpy_msg
    from sensor_msgs.msg import LaserScan
    from std_msgs.msg import Bool, UInt32

    from summit_xl_sim.world import World

    world = World.from_yaml(os.path.join(WS, "src", "summit_xl_sim", "worlds", "course_building.yaml"))
    log = os.path.join(OUT, "demo_tour_launch.log")
    args = ["summit_xl_sim", "tour.launch", f"speed:={SIM_SPEED}", f"gui:={'true' if gui else 'false'}"]
    with RoslaunchSession(args, log=log) as session:
        rospy.init_node("demo", anonymous=True, disable_signals=True)
        lock = threading.Lock()
        state = {"traj": [], "pose": None, "done": False, "coll": 0, "scan": None, "scan_pose": None}

        def on_truth(msg):
            q = msg.pose.pose.orientation
            yaw = math.atan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y * q.y + q.z * q.z))
            with lock:
                state["pose"] = (msg.pose.pose.position.x, msg.pose.pose.position.y, yaw)
                state["traj"].append(state["pose"][:2])

        def on_scan(msg):
            with lock:
                pose = state["pose"]
                # Keep the scan taken nearest the fetch room's centre: it shows the table legs.
                if pose is not None and (state["scan_pose"] is None or
                                         math.hypot(pose[0] - 16.0, pose[1] - 3.5)
                                         < math.hypot(state["scan_pose"][0] - 16.0, state["scan_pose"][1] - 3.5)):
                    state["scan"], state["scan_pose"] = np.array(msg.ranges), pose

        rospy.Subscriber("/base_pose_ground_truth", Odometry, on_truth, queue_size=100)
        rospy.Subscriber("/hokuyo_base/scan", numpy_msg(LaserScan), on_scan, queue_size=2)
        rospy.Subscriber("/tour_driver/done", Bool, lambda m: state.update(done=m.data), queue_size=1)
        rospy.Subscriber("/collisions", UInt32, lambda m: state.update(coll=m.data), queue_size=1)
        wait_for(lambda: state["pose"] is not None, 60, "the simulator's ground truth", session)
        progress.line(rospy.Time.now().to_sec(), f"simulator up at {SIM_SPEED:.0f}x real time; "
                      f"tour driver starting at ({state['pose'][0]:.1f}, {state['pose'][1]:.1f})")
        room, t_start, wall_start = None, rospy.Time.now().to_sec(), time.monotonic()
        while not state["done"]:
            if not session.alive():
                raise RuntimeError(f"the launch ended early (see {log})")
            with lock:
                pose = state["pose"]
            here = room_of(pose[0], pose[1])
            if here and here != room:
                room = here
                progress.line(rospy.Time.now().to_sec(), f"entered the {here}")
            if time.monotonic() - wall_start > 300:
                raise RuntimeError("the tour did not finish within 300 s of wall time")
            time.sleep(0.05)
        sim_t = rospy.Time.now().to_sec() - t_start
        wall_t = time.monotonic() - wall_start
        with lock:
            traj = list(state["traj"])
            pose, ranges = state["scan_pose"], state["scan"]
        progress.line(rospy.Time.now().to_sec(), f"tour finished, {state['coll']} collisions")
    length = float(np.sum(np.hypot(*np.diff(np.array(traj), axis=0).T))) if len(traj) > 1 else 0.0
    scan_xy = []
    if ranges is not None:
        lx, ly = pose[0] + 0.25 * math.cos(pose[2]), pose[1] + 0.25 * math.sin(pose[2])
        ang = np.linspace(-2.356194490192345, 2.356194490192345, len(ranges)) + pose[2]
        ok = np.isfinite(ranges)
        scan_xy = np.column_stack([lx + ranges[ok] * np.cos(ang[ok]), ly + ranges[ok] * np.sin(ang[ok])])
    picture = os.path.join(OUT, "demo_tour.png")
    draw_world_picture(world, traj, pose, scan_xy, picture)
    progress.line(rospy.Time.now().to_sec(), f"picture written: {os.path.relpath(picture, WS)}")
    ok = state["coll"] == 0
    return {"step": "tour the building (sim + tour driver)", "result": "ok" if ok else "COLLISION",
            "sim_s": sim_t, "wall_s": wall_t,
            "detail": f"{length:.1f} m driven, {state['coll']} collisions, {sim_t / max(wall_t, 1e-9):.1f}x real time"}


STEPS = [step_tour]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--gui", action="store_true", help="open rviz (needs a display)")
    args = ap.parse_args()
    os.makedirs(OUT, exist_ok=True)
    progress = Progress()
    rows = []
    for step in STEPS:
        rows.append(step(progress, args.gui))
    print("\n| step | result | sim time [s] | wall time [s] | detail |\n| --- | --- | --- | --- | --- |")
    for r in rows:
        print(f"| {r['step']} | {r['result']} | {r['sim_s']:.1f} | {r['wall_s']:.1f} | {r['detail']} |")
    return 0 if all(r["result"] == "ok" for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
