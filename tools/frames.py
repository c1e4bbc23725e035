#!/usr/bin/python3
"""`make frames`: the tf tree of the simulated Summit XL as output/frames.pdf and .png.

What the course's first step does by hand ("rosrun tf2_tools view_frames.py" while the
robot runs), made self-contained:
  1. starts its own ROS master on a free TCP port (never the default 11311), by way of
     `roslaunch -p PORT summit_xl_sim sim.launch speed:=1` in its own process group;
  2. waits until tf is flowing (a message on /tf);
  3. runs `rosrun tf2_tools view_frames.py` inside output/ (it listens 5 s of sim time,
     then writes frames.gv and frames.pdf into its working directory);
  4. renders frames.png: pdftoppm (poppler-utils) when installed, else ImageMagick's
     `convert -density 150`, else graphviz `dot -Tpng` on the same frames.gv;
  5. always stops the launch it started (SIGINT to the group, then SIGKILL).

Run with the workspace sourced: /usr/bin/python3 tools/frames.py [--out DIR] [--timeout S]
"""
import argparse
import os
import shutil
import signal
import socket
import subprocess
import sys
import time

from summit_nav_common.testing.roslaunch_session import free_port, stop_process_tree

WS = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def ros_env(port):
    env = dict(os.environ)
    # The ROS Python first: a pyenv/conda python3 earlier on PATH has no rospy.
    env["PATH"] = "/usr/bin:/bin:/usr/sbin:/sbin:" + env.get("PATH", "")
    env["ROS_MASTER_URI"] = "http://localhost:%d" % port
    env.setdefault("ROS_HOSTNAME", "localhost")
    env["PYTHONUNBUFFERED"] = "1"
    return env


def stop_group(proc, name, grace=20.0):
    """Stop a launched process tree (see roslaunch_session.stop_process_tree)."""
    if proc is not None and proc.poll() is None:
        print("frames: stopping %s" % name, flush=True)
    stop_process_tree(proc, grace)


def wait_for_tf(env, launch, deadline):
    """True once one message arrives on /tf (the simulator's odom -> base_footprint)."""
    while time.time() < deadline:
        if launch.poll() is not None:
            return False
        left = max(1.0, min(10.0, deadline - time.time()))
        try:
            r = subprocess.run(["rostopic", "echo", "-n", "1", "/tf"], env=env,
                               stdout=subprocess.PIPE, stderr=subprocess.DEVNULL,
                               timeout=left)
            if r.returncode == 0 and b"transforms" in r.stdout:
                return True
        except subprocess.TimeoutExpired:
            pass
        time.sleep(0.5)
    return False


def to_png(out_dir):
    """frames.pdf -> frames.png; returns (path or None, how)."""
    pdf = os.path.join(out_dir, "frames.pdf")
    png = os.path.join(out_dir, "frames.png")
    gv = os.path.join(out_dir, "frames.gv")
    if os.path.exists(png):
        os.remove(png)
    attempts = []
    if shutil.which("pdftoppm"):
        attempts.append(("pdftoppm (poppler-utils)",
                         ["pdftoppm", "-png", "-r", "150", "-singlefile", pdf,
                          os.path.join(out_dir, "frames")]))
    if os.path.exists("/usr/bin/convert"):
        # /usr/bin: not a stand-in earlier on PATH. Needs ghostscript and a policy.xml
        # that allows the PDF coder (Debian's default forbids it).
        attempts.append(("ImageMagick convert", ["/usr/bin/convert", "-density", "150", pdf,
                                                 "-background", "white", "-flatten", png]))
    if shutil.which("dot") and os.path.exists(gv):
        attempts.append(("graphviz dot -Tpng (from frames.gv; no PDF rasteriser available)",
                         ["dot", "-Tpng", "-Gdpi=150", gv, "-o", png]))
    for how, cmd in attempts:
        try:
            r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, timeout=60)
        except (OSError, subprocess.TimeoutExpired) as e:
            print("frames: %s failed: %s" % (how, e), flush=True)
            continue
        if r.returncode == 0 and os.path.exists(png) and os.path.getsize(png) > 0:
            return png, how
        msg = r.stderr.decode(errors="replace").strip().splitlines()
        print("frames: %s failed: %s" % (how, " | ".join(msg)[:400] if msg
                                          else "exit %d" % r.returncode), flush=True)
    return None, "no converter worked (install poppler-utils for pdftoppm)"


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=os.path.join(WS, "output"), help="output directory")
    ap.add_argument("--timeout", type=float, default=60.0,
                    help="seconds to wait for tf, and again for view_frames")
    args = ap.parse_args()
    out_dir = os.path.abspath(args.out)
    os.makedirs(out_dir, exist_ok=True)
    for name in ("frames.pdf", "frames.gv"):
        if os.path.exists(os.path.join(out_dir, name)):
            os.remove(os.path.join(out_dir, name))

    port = free_port()
    env = ros_env(port)
    log_path = os.path.join(out_dir, "frames_launch.log")
    print("frames: ROS master on port %d, launching summit_xl_sim sim.launch (log %s)"
          % (port, log_path), flush=True)
    launch = None
    log = open(log_path, "wb")
    try:
        launch = subprocess.Popen(
            ["roslaunch", "-p", str(port), "summit_xl_sim", "sim.launch", "speed:=1"],
            env=env, stdout=log, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
            start_new_session=True)
        if not wait_for_tf(env, launch, time.time() + args.timeout):
            print("frames: no tf within %.0f s (launch %s); see %s"
                  % (args.timeout, "exited" if launch.poll() is not None else "running",
                     log_path), file=sys.stderr, flush=True)
            return 1
        print("frames: tf is flowing; running tf2_tools view_frames.py in %s" % out_dir,
              flush=True)
        vf = subprocess.Popen(["rosrun", "tf2_tools", "view_frames.py"], cwd=out_dir, env=env,
                              start_new_session=True)
        try:
            rc = vf.wait(timeout=args.timeout)
        except subprocess.TimeoutExpired:
            stop_group(vf, "view_frames", grace=5.0)
            print("frames: view_frames did not finish in %.0f s" % args.timeout,
                  file=sys.stderr, flush=True)
            return 1
        pdf = os.path.join(out_dir, "frames.pdf")
        if rc != 0 or not os.path.exists(pdf):
            if not shutil.which("dot"):
                print("frames: view_frames needs graphviz (`dot`), which is missing",
                      file=sys.stderr)
            print("frames: view_frames failed (exit %d, frames.pdf %s)"
                  % (rc, "written" if os.path.exists(pdf) else "missing"), file=sys.stderr)
            return 1
    finally:
        stop_group(launch, "roslaunch")
        log.close()

    png, how = to_png(out_dir)
    print("frames: tf tree written to\n  %s\n  %s" % (pdf, os.path.join(out_dir, "frames.gv")))
    if png:
        print("  %s   (rendered with %s)" % (png, how))
        return 0
    print("frames: could not render frames.png: %s" % how, file=sys.stderr)
    return 1


if __name__ == "__main__":
    sys.exit(main())
