#!/usr/bin/python3
"""Side by side: a map_server executable's /map against map_io.load_map, cell for cell,
on the image formats users hand map_server.

Writes small images (grey, grey + alpha, RGB, RGBA, palette with and without a
transparent index, bilevel, 16-bit grey; as PNG, BMP, PGM/PPM and JPEG), one map YAML per
image x mode (trinary, scale, raw) x negate (0, 1), starts a roscore on a free port, runs
the executable on each YAML, takes the latched /map and compares its data with what
summit_nav_common.map_io.load_map reads from the same YAML. Prints each case that
differs (cells, a few values of each) and exits 1 if any does, 0 if all agree.

--node EXECUTABLE: the map_server to compare with (e.g. the real one, built outside the
project; default: ours, nodes/map_server), started as node `map_server` in the
environment a bash has after sourcing --node-setup, when given. The files are kept in
--out DIR, or in a temporary folder when a case differs. Every process started here is
stopped, also on failure.

Usage: compare_map_server.py [--node EXE [--node-setup SETUP_BASH]] [--out DIR]
  e.g. compare_map_server.py --node /tmp/peers_ws/devel/lib/map_server/map_server \\
           --node-setup /tmp/peers_ws/devel/setup.bash
"""
import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import threading

import numpy as np
from PIL import Image

from summit_nav_common.testing.roslaunch_session import (Roscore, check_node_args, exit_on_sigterm, sourced_env,
                                                         stop_process_tree, wait_for)

HERE = os.path.dirname(os.path.abspath(__file__))

NODE = os.path.join(HERE, "..", "nodes", "map_server")
MAP_TIMEOUT = 20.0   # [s wall] for the node to publish /map


def write_images(folder, seed=5, height=23, width=31):
    """The test images, and one YAML per image x mode x negate; returns the YAML names."""
    rng = np.random.default_rng(seed)
    grey = rng.integers(0, 256, (height, width), dtype=np.uint8)
    grey[:, :4], grey[:, 4:8], grey[:, 8:10] = 0, 254, 205   # map_saver's three values
    alpha = rng.integers(0, 256, (height, width), dtype=np.uint8)
    alpha[:, ::3], alpha[::4, :] = 255, 0
    rgb = rng.integers(0, 256, (height, width, 3), dtype=np.uint8)
    wide = rng.integers(0, 65536, (height, width)).astype(np.uint16)
    images = {
        "grey.png": Image.fromarray(grey, "L"), "grey.pgm": Image.fromarray(grey, "L"),
        "grey.bmp": Image.fromarray(grey, "L"), "grey.jpg": Image.fromarray(grey, "L"),
        "grey_alpha.png": Image.fromarray(np.dstack([grey, alpha]), "LA"),
        "rgb.png": Image.fromarray(rgb, "RGB"), "rgb.bmp": Image.fromarray(rgb, "RGB"),
        "rgb.ppm": Image.fromarray(rgb, "RGB"), "rgba.png": Image.fromarray(np.dstack([rgb, alpha]), "RGBA"),
        "palette.png": Image.fromarray(rgb, "RGB").quantize(16),
        "palette.bmp": Image.fromarray(rgb, "RGB").quantize(8),
        "bilevel.png": Image.fromarray(grey, "L").convert("1"),
        "grey16.png": Image.fromarray(wide, "I;16"),
    }
    images["palette_transparent.png"] = Image.fromarray(rgb, "RGB").quantize(16)
    for name, im in images.items():
        im.save(os.path.join(folder, name), **({"transparency": 3} if name == "palette_transparent.png" else {}))
    names = []
    for image in sorted(images):
        for mode in ("trinary", "scale", "raw"):
            for negate in (0, 1):
                name = f"{image}.{mode}.{negate}.yaml"
                with open(os.path.join(folder, name), "w") as f:
                    f.write(f"image: {image}\nresolution: 0.1\norigin: [0.0, 0.0, 0.0]\nnegate: {negate}\n"
                            f"occupied_thresh: 0.65\nfree_thresh: 0.196\nmode: {mode}\n")
                names.append(name)
    return names


def node_map(cmd, env, yaml_path, log_path):
    """The node's first /map (OccupancyGrid) for yaml_path; RuntimeError naming the case
    and the node's last output when it ends or publishes nothing."""
    import rospy
    from nav_msgs.msg import OccupancyGrid
    got = []
    event = threading.Event()

    def keep(msg):
        got.append(msg)
        event.set()

    with open(log_path, "w") as log:
        proc = subprocess.Popen(cmd + [yaml_path, "__name:=map_server"], env=env, stdout=log,
                                stderr=subprocess.STDOUT, start_new_session=True)
    sub = rospy.Subscriber("/map", OccupancyGrid, keep)
    try:
        wait_for(lambda: event.is_set() or proc.poll() is not None, MAP_TIMEOUT, f"/map for {yaml_path}")
    except RuntimeError:
        pass
    finally:
        sub.unregister()
        stop_process_tree(proc, grace=5.0)
    if not got:
        with open(log_path) as f:
            last = f.read().strip().splitlines()[-3:]
        raise RuntimeError(f"{os.path.basename(yaml_path)}: no /map from the node: {' | '.join(last)}")
    m = got[0]
    return np.array(m.data, np.int8).reshape(m.info.height, m.info.width)


def compare(yaml_names, folder, cmd, env):
    """[(case, text)] of every case where the node and load_map differ."""
    import rospy
    from summit_nav_common.map_io import MapError, load_map
    rospy.init_node("compare_map_server", anonymous=True, disable_signals=True)
    differ = []
    for name in yaml_names:
        path = os.path.join(folder, name)
        try:
            theirs = node_map(cmd, env, path, os.path.join(folder, name + ".log"))
        except RuntimeError as e:
            theirs, why = None, str(e)
        try:
            ours = load_map(path).data
        except MapError as e:
            ours, our_why = None, str(e)
        if theirs is None or ours is None:
            if not (theirs is None and ours is None):
                differ.append((name, why if theirs is None else f"ours refuses: {our_why}"))
            continue
        if ours.shape != theirs.shape:
            differ.append((name, f"shape {ours.shape} (ours) against {theirs.shape}"))
        elif not np.array_equal(ours, theirs):
            bad = ours != theirs
            differ.append((name, f"{int(bad.sum())} of {bad.size} cells; ours {ours[bad][:4].tolist()}, "
                                 f"theirs {theirs[bad][:4].tolist()}"))
    return differ


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--node", help="map_server executable (default: ours)")
    ap.add_argument("--node-setup", help="bash file sourced for its environment")
    ap.add_argument("--out", help="keep the images, YAMLs and node logs here")
    args = ap.parse_args()
    try:
        check_node_args(args.node, args.node_setup)
    except ValueError as e:
        sys.exit(f"compare_map_server: {e}")
    exit_on_sigterm()
    env = sourced_env(args.node_setup, dict(os.environ), extend=True) if args.node_setup else dict(os.environ)
    cmd = [args.node] if args.node else [sys.executable, NODE]
    folder = args.out or tempfile.mkdtemp(prefix="compare_map_server_")
    os.makedirs(folder, exist_ok=True)
    names = write_images(folder)
    with Roscore(log=os.path.join(folder, "roscore.log"), caller="/compare_map_server") as core:
        os.environ["ROS_MASTER_URI"] = core.env["ROS_MASTER_URI"]
        env["ROS_MASTER_URI"] = core.env["ROS_MASTER_URI"]
        differ = compare(names, folder, cmd, env)
    for name, text in differ:
        print(f"{name:36s} {text}")
    kept = args.out or differ
    if not kept:
        shutil.rmtree(folder, ignore_errors=True)
    print(f"{len(names) - len(differ)} of {len(names)} cases agree ({args.node or 'our map_server'} "
          f"against map_io.load_map)" + (f"; files in {folder}" if kept else ""))
    sys.exit(1 if differ else 0)


if __name__ == "__main__":
    main()
