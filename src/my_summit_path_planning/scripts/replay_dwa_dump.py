#!/usr/bin/python3
"""Replay what move_base's DWA saw when it found no valid command (~debug_dump_dir).

    replay_dwa_dump.py DUMP.pkl [--png OUT.png] [--scale 8] [--turn-around]

Loads a dump (local costmap, DWAPlanner with its plan and state, pose, velocity), runs
DWAPlanner.compute_velocity on it again and prints the result; with --png draws the
local costmap round the robot (black: lethal, grey: inscribed, light: inflated, dark
grey: unknown), the padded footprint (red), the global plan (blue) and, when a command
is found, its trajectory (green); with --turn-around also prints the moves the
turn_around recovery would search from there. For offline study of wedges; the copy is
independent of the running robot.
"""
import argparse
import math
import pickle
import sys

import cv2
import numpy as np

from my_summit_path_planning.cost_values import INSCRIBED_INFLATED_OBSTACLE, LETHAL_OBSTACLE, NO_INFORMATION


def render(state, result, scale, half=2.0):
    """BGR image of the costmap within half [m] of the robot, scale pixels per cell."""
    cm, (x, y, yaw) = state["costmap"], state["pose"]
    res = cm.resolution
    c0 = int(math.floor((x - half - cm.origin_x) / res))
    r0 = int(math.floor((y - half - cm.origin_y) / res))
    n = int(round(2 * half / res))
    img = np.full((n, n, 3), 255, np.uint8)
    h, w = cm.data.shape
    rows, cols = np.mgrid[r0:r0 + n, c0:c0 + n]
    inside = (rows >= 0) & (cols >= 0) & (rows < h) & (cols < w)
    cost = np.full((n, n), NO_INFORMATION, np.int32)
    cost[inside] = cm.data[rows[inside], cols[inside]]
    img[(cost > 0) & (cost < INSCRIBED_INFLATED_OBSTACLE)] = (215, 215, 215)
    img[cost == INSCRIBED_INFLATED_OBSTACLE] = (150, 150, 150)
    img[cost == LETHAL_OBSTACLE] = (0, 0, 0)
    img[cost == NO_INFORMATION] = (90, 90, 90)
    img = cv2.resize(img, (n * scale, n * scale), interpolation=cv2.INTER_NEAREST)

    def px(pts):
        pts = np.asarray(pts, np.float64)
        u = (pts[:, 0] - cm.origin_x) / res - c0
        v = (pts[:, 1] - cm.origin_y) / res - r0
        return np.column_stack([u * scale, v * scale]).round().astype(np.int32)

    dwa = state["dwa"]
    if dwa.plan is not None:
        cv2.polylines(img, [px(dwa.plan[:, :2])], False, (255, 0, 0), 1)
    if result.trajectory is not None:
        cv2.polylines(img, [px(result.trajectory[:, :2])], False, (0, 160, 0), 2)
    c, s = math.cos(yaw), math.sin(yaw)
    poly = dwa.footprint.polygon
    world = np.column_stack([x + c * poly[:, 0] - s * poly[:, 1], y + s * poly[:, 0] + c * poly[:, 1]])
    cv2.polylines(img, [px(world)], True, (0, 0, 255), 1)
    nose = np.array([[x, y], [x + 0.3 * c, y + 0.3 * s]])
    cv2.polylines(img, [px(nose)], False, (0, 0, 255), 1)
    return cv2.flip(img, 0)   # row 0 = lowest y: north up


def describe_manoeuvre(state):
    """'turn_around: 11 moves (0.05 m, 0.10 rad, keeping 5 mm of padding): right, ...' or why none."""
    from my_summit_path_planning.recovery import search_manoeuvre
    moves, (step, turn, keep) = search_manoeuvre(state["dwa"].footprint, state["costmap"], state["pose"])
    if moves is None:
        return "turn_around: no way out found"
    names = [("fwd" if v > 0 else "back" if v < 0 else "")
             + ("-" if v and w else "") + ("left" if w > 0 else "right" if w < 0 else "") for v, w in moves]
    return (f"turn_around: {len(moves)} moves ({step:.2f} m, {turn:.2f} rad, keeping {1000 * keep:.0f} mm of "
            "padding): " + ", ".join(names))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("dump")
    ap.add_argument("--png", help="draw the costmap, footprint, plan and trajectory here")
    ap.add_argument("--scale", type=int, default=8, help="pixels per costmap cell")
    ap.add_argument("--turn-around", action="store_true",
                    help="print the moves turn_around's search finds from the dumped pose")
    args = ap.parse_args(argv)
    try:
        with open(args.dump, "rb") as f:
            state = pickle.load(f)
    except (OSError, pickle.UnpicklingError, EOFError) as e:
        print(f"cannot read {args.dump}: {e}", file=sys.stderr)
        return 2
    res = state["dwa"].compute_velocity(state["pose"], state["velocity"], state["costmap"])
    x, y, yaw = state["pose"]
    print(f"t {state['stamp']:.2f} s: pose ({x:.3f}, {y:.3f}, yaw {yaw:.3f}), velocity {state['velocity']}")
    print(f"mode {res.mode}, ok {res.ok}, cmd {res.cmd}, {res.n_valid} of {res.n_samples} samples valid")
    if res.reason:
        print(f"reason: {res.reason}")
    if args.turn_around:
        print(describe_manoeuvre(state))
    if args.png:
        cv2.imwrite(args.png, render(state, res, args.scale))
        print(f"picture: {args.png}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
