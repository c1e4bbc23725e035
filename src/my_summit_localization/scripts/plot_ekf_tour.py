#!/usr/bin/python3
"""Picture of one tour: ground truth, the raw skid-steer odometry and the EKF's fused odometry.

Reads a tour recorded by bench_ekf.py (/odom, /base_pose_ground_truth) and the node's
odometry/filtered from the same run, puts both odometries into the world frame at the
robot's start pose (where their odom frame began), and draws them over the world's map:
green the truth, red the raw wheel odometry, blue the fused (thin, on top of the truth's
wider line); each track's end marked
with its heading. The legend gives each one's heading error after the tour and ATE
(my_summit_localization.odom_error, no alignment).

    plot_ekf_tour.py [--tour output/ekf_bags/seed1.bag] [--fused output/bench_ekf/fused_seed1.bag]
                     [--world WORLD.yaml] [--out docs/img/ekf_tour.png]
"""
import argparse
import math
import os

import cv2
import numpy as np

from my_summit_localization.odom_error import odom_error
from summit_nav_common.geometry import compose
from summit_nav_common.map_io import load_map

HERE = os.path.dirname(os.path.abspath(__file__))
WS = os.path.dirname(os.path.dirname(os.path.dirname(HERE)))
WORLD = os.path.join(WS, "src", "summit_xl_sim", "worlds", "course_building.yaml")
SCALE = 3            # image pixels per map cell
MARGIN = 1.0         # [m] around the tracks
COLOURS = {"truth": (0, 150, 0), "raw": (0, 0, 220), "fused": (200, 90, 0)}   # BGR


def read_tracks(bag, topics):
    """{topic: rows (t, x, y, yaw)} of nav_msgs/Odometry topics in a bag."""
    import rosbag
    out = {t: [] for t in topics}
    with rosbag.Bag(bag) as b:
        for topic, msg, _ in b.read_messages(topics=list(topics)):
            p, q = msg.pose.pose.position, msg.pose.pose.orientation
            yaw = math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))
            out[topic].append((msg.header.stamp.to_sec(), p.x, p.y, yaw))
    return {t: np.array(rows, dtype=np.float64).reshape(-1, 4) for t, rows in out.items()}


def draw(world, tracks, labels, out):
    """The map cropped to the tracks, with each track (world frame rows) drawn on it."""
    allxy = np.vstack([t[:, 1:3] for t in tracks.values()])
    lo, hi = allxy.min(axis=0) - MARGIN, allxy.max(axis=0) + MARGIN
    res = world.resolution
    ox, oy, _ = world.origin
    # the canvas covers the tracks even where they leave the map (unknown grey there)
    c0, r0 = int(math.floor((lo[0] - ox) / res)), int(math.floor((lo[1] - oy) / res))
    c1, r1 = int(math.ceil((hi[0] - ox) / res)), int(math.ceil((hi[1] - oy) / res))
    grey = np.where(world.data == 100, 60, np.where(world.data == 0, 255, 215)).astype(np.uint8)
    base = np.full((r1 - r0, c1 - c0), 215, np.uint8)
    sr0, sr1, sc0, sc1 = max(r0, 0), min(r1, world.height), max(c0, 0), min(c1, world.width)
    if sr1 > sr0 and sc1 > sc0:
        base[sr0 - r0:sr1 - r0, sc0 - c0:sc1 - c0] = grey[sr0:sr1, sc0:sc1]
    img = cv2.resize(cv2.cvtColor(base[::-1], cv2.COLOR_GRAY2BGR), None, fx=SCALE, fy=SCALE,
                     interpolation=cv2.INTER_NEAREST)
    h = img.shape[0]

    def px(x, y):
        return (int(round(((x - ox) / res - c0) * SCALE)), int(round(h - ((y - oy) / res - r0) * SCALE)))

    # the fused track last and thin: it runs on the truth's, which is drawn wider under it
    for name, width in (("raw", 2), ("truth", 4), ("fused", 1)):
        t = tracks[name]
        pts = np.array([px(x, y) for x, y in t[:, 1:3]], dtype=np.int32)
        cv2.polylines(img, [pts], False, COLOURS[name], width, cv2.LINE_AA)
        x, y, yaw = t[-1, 1:4]
        cv2.circle(img, px(x, y), 7, COLOURS[name], 2, cv2.LINE_AA)
        cv2.line(img, px(x, y), px(x + 0.8 * math.cos(yaw), y + 0.8 * math.sin(yaw)), COLOURS[name], 2, cv2.LINE_AA)
    x0, y0 = tracks["truth"][0, 1:3]
    cv2.circle(img, px(x0, y0), 5, (0, 0, 0), -1, cv2.LINE_AA)
    legend = np.full((26 * len(labels) + 12, img.shape[1], 3), 255, np.uint8)
    for k, (name, text) in enumerate(labels):
        y = 24 + 26 * k
        cv2.line(legend, (10, y - 6), (40, y - 6), COLOURS[name], 3, cv2.LINE_AA)
        cv2.putText(legend, text, (50, y), cv2.FONT_HERSHEY_SIMPLEX, 0.55, (20, 20, 20), 1, cv2.LINE_AA)
    picture = np.vstack([legend, img])
    tmp = out[:-4] + ".tmp.png"
    if not cv2.imwrite(tmp, picture):
        raise OSError(f"could not write {tmp}")
    os.replace(tmp, out)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tour", default=os.path.join(WS, "output", "ekf_bags", "seed1.bag"))
    ap.add_argument("--fused", default=os.path.join(WS, "output", "bench_ekf", "fused_seed1.bag"))
    ap.add_argument("--world", default=WORLD)
    ap.add_argument("--out", default=os.path.join(WS, "docs", "img", "ekf_tour.png"))
    args = ap.parse_args()
    rec = read_tracks(args.tour, ("/odom", "/base_pose_ground_truth"))
    fused = read_tracks(args.fused, ("/odometry/filtered",))["/odometry/filtered"]
    truth, raw = rec["/base_pose_ground_truth"], rec["/odom"]
    t_end = min(raw[-1, 0], fused[-1, 0])
    start = truth[0, 1:4]
    tracks = {"truth": truth[truth[:, 0] <= t_end]}
    labels = [("truth", "ground truth (the simulator)")]
    for name, track, what in (("raw", raw, "raw wheel odometry (skid steer, /odom)"),
                              ("fused", fused, "EKF: wheels + IMU (/odometry/filtered)")):
        track = track[track[:, 0] <= t_end]
        e = odom_error(track, truth, t_end=t_end)
        world_rows = np.column_stack([track[:, 0], compose(start, track[:, 1:4])])
        tracks[name] = world_rows
        labels.append((name, f"{what}: heading error at the end {math.degrees(e.final_heading):.2f} deg, "
                             f"ATE {e.ate:.3f} m"))
    draw(load_map(args.world), tracks, labels, args.out)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
