#!/usr/bin/python3
"""The README's loop-closing picture: a CARMEN log mapped by the karto core without and with
loop closing, side by side.

The log becomes the scans and seeded drifted odometry the slam_bag benchmark's bag holds
(carmen_bag.bag_scans, as_received), fed to my_summit_mapping.karto.KartoMapper as the
slam_karto node feeds it (slam_karto's defaults, resolution 0.05 m). Left: do_loop_closing
false, the scan-matched chain alone, whose small heading errors pile up over the loop;
right: the same scans with loop closing, the graph optimized after each closure. Each
panel: the map rendered from the graph's poses (map_saver's colours), the log's corrected
trajectory aligned to the graph (blue), the graph's nodes (red), its loop-closure edges
(green), the title with the final graph's aligned ATE against the corrected poses.

Usage: karto_loop_picture.py LOG [--seed 1] [--scans N] [--out docs/img/karto_loop_closure.png]
  e.g. karto_loop_picture.py data/carmen/intel-corrected.log.gz   (the README's picture)
"""
import argparse
import dataclasses
import os
import sys
import time

import cv2
import numpy as np

from my_summit_mapping import carmen, carmen_bag, metrics
from my_summit_mapping.karto.mapper import KartoMapper, KartoParams, LaserGeometry

HERE = os.path.dirname(os.path.abspath(__file__))
WS = os.path.abspath(os.path.join(HERE, "..", "..", ".."))
OUT = os.path.join(WS, "docs", "img", "karto_loop_closure.png")
RESOLUTION = 0.05      # [m/cell] as the benchmark runs the node
PANEL_PX = 560         # [px] the longer side of each panel
TITLE_PX = 68          # [px] band above each panel for its title (3 lines)
NODE_COLOR = (40, 40, 220)     # BGR red
LOOP_COLOR = (40, 170, 40)     # BGR green
TRUTH_COLOR = (230, 160, 40)   # BGR blue


def run(scans, do_loop_closing):
    """KartoMapper over the scans; (mapper, CPU seconds)."""
    params, _ = KartoParams.from_params(dict(resolution=RESOLUTION, do_loop_closing=do_loop_closing))
    n = scans.ranges.shape[1]
    laser = LaserGeometry(scans.angle_min, scans.angle_increment, n, carmen_bag.RANGE_MIN, scans.range_max,
                          mount=(scans.laser_offset, 0.0, 0.0))
    mapper = KartoMapper(params, laser)
    t0 = time.process_time()
    for k in range(len(scans.stamps)):
        mapper.add_scan(scans.ranges[k], scans.odometry[k], float(scans.stamps[k]))
    return mapper, time.process_time() - t0


def node_references(mapper, scans):
    """The corrected poses (N, 3) of the graph nodes' scans."""
    stamps = np.asarray(mapper.node_stamps(), float)
    return scans.reference[np.abs(scans.stamps[None, :] - stamps[:, None]).argmin(axis=1)]


def panel(mapper, reference, title):
    """One panel: the map, the reference trajectory aligned to the graph, the nodes and
    loop edges, the title above (BGR image)."""
    grid, (ox, oy) = mapper.occupancy_grid()
    img = np.full(grid.shape, 205, np.uint8)
    img[grid == 0] = 254
    img[grid == 100] = 0
    scale = PANEL_PX / max(grid.shape)
    rgb = cv2.cvtColor(cv2.resize(img, None, fx=scale, fy=scale, interpolation=cv2.INTER_AREA), cv2.COLOR_GRAY2BGR)
    poses = mapper.node_poses()

    def px(xy):
        # row 0 of the grid is the lowest y: flipped when drawn below
        return (int(round((xy[0] - ox) / RESOLUTION * scale)), int(round((xy[1] - oy) / RESOLUTION * scale)))

    canvas = np.ascontiguousarray(rgb)
    rot, shift = metrics.rigid_alignment_2d(reference[:, :2], poses[:, :2])
    truth = reference[:, :2] @ rot.T + shift
    cv2.polylines(canvas, [np.array([px(p) for p in truth], np.int32).reshape(-1, 1, 2)], False, TRUTH_COLOR, 1,
                  cv2.LINE_AA)
    for i, j, kind in mapper.edges():
        if kind == "loop":
            cv2.line(canvas, px(poses[i]), px(poses[j]), LOOP_COLOR, 2, cv2.LINE_AA)
    for p in poses:
        cv2.circle(canvas, px(p), 1, NODE_COLOR, -1, cv2.LINE_AA)
    canvas = np.flipud(canvas)
    band = np.full((TITLE_PX, canvas.shape[1], 3), 255, np.uint8)
    for k, line in enumerate(title.split("\n")):
        cv2.putText(band, line, (8, 20 + 20 * k), cv2.FONT_HERSHEY_SIMPLEX, 0.5, (0, 0, 0), 1, cv2.LINE_AA)
    return np.vstack([band, canvas])


def side_by_side(left, right):
    h = max(left.shape[0], right.shape[0])
    pad = lambda im: np.vstack([im, np.full((h - im.shape[0], im.shape[1], 3), 255, np.uint8)])  # noqa: E731
    gap = np.full((h, 12, 3), 255, np.uint8)
    return np.hstack([pad(left), gap, pad(right)])


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("log", help="CARMEN corrected log (.log / .log.gz)")
    parser.add_argument("--seed", type=int, default=1, help="odometry drift seed (the benchmark's)")
    parser.add_argument("--scans", type=int, help="only the first SCANS scans of the log")
    parser.add_argument("--out", default=OUT, help="PNG to write (default %(default)s)")
    args = parser.parse_args(argv)
    try:
        log = carmen.read_carmen(args.log)
    except (OSError, ValueError) as e:
        print(f"karto_loop_picture: error: {e}", file=sys.stderr)
        return 2
    if args.scans:
        log = dataclasses.replace(log, ranges=log.ranges[:args.scans], poses=log.poses[:args.scans],
                                  timestamps=log.timestamps[:args.scans])
    scans = carmen_bag.as_received(carmen_bag.bag_scans(log, args.seed))
    odom_ate = float(metrics.ate_rmse(scans.odometry, scans.reference))
    name = os.path.basename(args.log).split("-")[0]
    panels = []
    for closing, label in ((False, "without loop closing"), (True, "with loop closing")):
        mapper, cpu = run(scans, closing)
        reference = node_references(mapper, scans)
        ate = float(metrics.ate_rmse(mapper.node_poses(), reference))
        loops = sum(1 for e in mapper.edges() if e[2] == "loop")
        print(f"{label}: {len(mapper.node_poses())} nodes, {loops} loop edges, final ATE {ate:.3f} m, "
              f"CPU {cpu:.1f} s", flush=True)
        panels.append(panel(mapper, reference, f"{name}, karto {label}\n{len(mapper.node_poses())} nodes, {loops} loop "
                                    f"edges, ATE {ate:.2f} m (odometry {odom_ate:.2f} m)\n"
                                    "red: nodes, green: loop edges, blue: the log's path"))
    os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
    tmp = args.out + ".tmp.png"
    cv2.imwrite(tmp, side_by_side(*panels))
    os.replace(tmp, args.out)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
