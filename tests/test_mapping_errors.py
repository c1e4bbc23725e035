"""Bad input to the map nodes: map_server fails at once naming the file and the field;
map_saver into a folder that is missing or not writable fails clearly, earlier files intact."""
import os
import signal
import subprocess
import time

import numpy as np
import pytest

from summit_nav_common.testing.roslaunch_session import Roscore, free_port, stop_process_tree, wait_for

TIMEOUT = 60  # [s] wall for one launch
GOOD_YAML = ("image: {image}\nresolution: 0.05\norigin: [0.0, 0.0, 0.0]\nnegate: 0\n"
             "occupied_thresh: 0.65\nfree_thresh: 0.196\n")


def env_for(tmp_path, port):
    return dict(os.environ, ROS_MASTER_URI=f"http://127.0.0.1:{port}", ROS_LOG_DIR=str(tmp_path / "log"),
                ROS_HOME=str(tmp_path))


def run(cmd, env, timeout=TIMEOUT):
    """Run cmd in its own process group; returns (seconds, return code, output)."""
    t0 = time.monotonic()
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=env,
                            start_new_session=True)
    try:
        out, _ = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        out, _ = proc.communicate()
        pytest.fail(f"{cmd} still running after {timeout} s:\n{out[-3000:]}")
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
    return time.monotonic() - t0, proc.returncode, out


def provide_map(tmp_path, map_file):
    """provide_map.launch with map_file on a private master (the node is required)."""
    port = free_port()
    return run(["roslaunch", "-p", str(port), "my_summit_mapping", "provide_map.launch", f"map_file:={map_file}"],
               env_for(tmp_path, port))


def write_pgm(path, pixels):
    h, w = pixels.shape
    path.write_bytes(f"P5\n{w} {h}\n255\n".encode() + pixels.astype(np.uint8).tobytes())


@pytest.mark.integration
def test_map_server_missing_image(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text(GOOD_YAML.format(image="gone.pgm"))
    secs, _, out = provide_map(tmp_path, bad)
    assert f"{bad}: field 'image'" in out and "gone.pgm does not exist" in out, out[-3000:]
    assert "REQUIRED process [map_server" in out, out[-3000:]
    assert secs < TIMEOUT / 2


@pytest.mark.integration
def test_map_server_malformed_yaml_and_unknown_mode(tmp_path):
    write_pgm(tmp_path / "m.pgm", np.full((4, 5), 254))
    bad = tmp_path / "bad.yaml"
    bad.write_text("image: [oops\n")
    _, _, out = provide_map(tmp_path, bad)
    assert f"{bad}: malformed YAML" in out, out[-3000:]
    bad.write_text(GOOD_YAML.format(image="m.pgm") + "mode: fancy\n")
    _, _, out = provide_map(tmp_path, bad)
    assert f"{bad}: field 'mode' must be one of trinary, scale, raw, got 'fancy'" in out, out[-3000:]
    bad.write_text(GOOD_YAML.format(image="m.pgm").replace("occupied_thresh: 0.65", "occupied_thresh: 1.5"))
    _, _, out = provide_map(tmp_path, bad)
    assert f"{bad}: field 'occupied_thresh' must be within [0, 1]" in out, out[-3000:]


REF_MAPS = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "data", "map_server_tests")
DEPRECATION = "Using deprecated map server interface. Please switch to new interface."


def map_server_launch(tmp_path, args):
    """A launch file starting map_server with args (required, as provide_map.launch)."""
    path = tmp_path / "deprecated.launch"
    path.write_text(f'<launch><node pkg="my_summit_mapping" type="map_server" name="map_server" '
                    f'args="{args}" output="screen" required="true"/></launch>\n')
    return str(path)


@pytest.mark.integration
def test_map_server_deprecated_image_resolution_form(tmp_path):
    """``map_server IMAGE RESOLUTION`` serves the image at that resolution, origin 0."""
    port = free_port()
    env = env_for(tmp_path, port)
    image = os.path.join(REF_MAPS, "testmap.png")
    server = subprocess.Popen(["roslaunch", "-p", str(port), map_server_launch(tmp_path, f"{image} 0.1")],
                              stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=env,
                              start_new_session=True)
    try:
        deadline = time.monotonic() + TIMEOUT  # wall: roslaunch starts its master first
        while True:
            _, code, out = run(["rostopic", "echo", "-n", "1", "/map_metadata"], env)
            if code == 0 or time.monotonic() > deadline or server.poll() is not None:
                break
            time.sleep(1.0)
        assert code == 0, out
        meta = {k.strip(): v.strip() for k, v in (l.split(":", 1) for l in out.splitlines()
                                                   if ":" in l and not l.startswith(" "))}
        assert (meta["width"], meta["height"]) == ("10", "10"), out
        assert float(meta["resolution"]) == pytest.approx(0.1), out
        _, code, origin = run(["rostopic", "echo", "-n", "1", "/map/info/origin/position"], env)
        assert code == 0 and "x: 0.0" in origin and "y: 0.0" in origin, origin
    finally:
        os.killpg(server.pid, signal.SIGINT)
        try:
            log, _ = server.communicate(timeout=20)
        except subprocess.TimeoutExpired:
            os.killpg(server.pid, signal.SIGKILL)
            log, _ = server.communicate()
    assert DEPRECATION in log, log[-3000:]


@pytest.mark.integration
@pytest.mark.parametrize("args, needle", [
    ("{tmp}/gone.png 0.1", "gone.png: image file does not exist"),
    ("{ref}/testmap.png ten", "argument RESOLUTION must be a positive number [m/cell], got 'ten'"),
    ("{ref}/testmap.png -0.1", "argument RESOLUTION must be a positive number [m/cell], got '-0.1'"),
    ("{ref}/testmap.png 0.1 extra", "expected 1 or 2 arguments, got 3"),
])
def test_map_server_deprecated_form_bad_arguments(tmp_path, args, needle):
    port = free_port()
    launch = map_server_launch(tmp_path, args.format(tmp=tmp_path, ref=REF_MAPS))
    secs, _, out = run(["roslaunch", "-p", str(port), launch], env_for(tmp_path, port))
    assert needle in out, out[-3000:]
    if "RESOLUTION" in needle or "expected 1 or 2" in needle:
        assert "DEPRECATED USAGE: map_server <map> <resolution>" in out, out[-3000:]
    assert "REQUIRED process [map_server" in out, out[-3000:]
    assert secs < TIMEOUT / 2


@pytest.mark.integration
def test_map_saver_into_missing_or_read_only_folder(tmp_path):
    env = env_for(tmp_path, free_port())  # no master: the saver must fail before waiting for one
    secs, code, out = run(["rosrun", "my_summit_mapping", "map_saver", "-f", str(tmp_path / "nowhere" / "my_map")], env)
    assert code == 1, out
    assert f"folder {tmp_path / 'nowhere'} does not exist" in out, out
    assert secs < 10

    folder = tmp_path / "maps"
    folder.mkdir()
    (folder / "my_map.pgm").write_bytes(b"earlier image")
    (folder / "my_map.yaml").write_text("earlier yaml\n")
    folder.chmod(0o500)
    try:
        if not os.access(folder, os.W_OK):  # root may write anywhere: then only the check above
            _, code, out = run(["rosrun", "my_summit_mapping", "map_saver", "-f", str(folder / "my_map")], env)
            assert code == 1 and "is not writable" in out, out
    finally:
        folder.chmod(0o700)
        assert (folder / "my_map.pgm").read_bytes() == b"earlier image"
        assert (folder / "my_map.yaml").read_text() == "earlier yaml\n"


COMMITTED_MAP = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))),
                             "src", "my_summit_mapping", "maps", "my_map.yaml")


@pytest.mark.integration
def test_map_saver_and_autosaver_save_the_served_map(tmp_path):
    """map_server -> map_saver (and map_autosaver, saving at shutdown) -> the same map."""
    from summit_nav_common.map_io import load_map
    port = free_port()
    env = env_for(tmp_path, port)
    server = subprocess.Popen(["roslaunch", "-p", str(port), "my_summit_mapping", "provide_map.launch"],
                              stdout=subprocess.DEVNULL, stderr=subprocess.STDOUT, env=env, start_new_session=True)
    try:
        _, code, out = run(["rosrun", "my_summit_mapping", "map_saver", "-f", str(tmp_path / "saved")], env)
        assert code == 0, out
        auto = subprocess.Popen(["rosrun", "my_summit_mapping", "map_autosaver", f"_path:={tmp_path / 'auto'}",
                                 "_interval:=100.0"], stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                text=True, env=env, start_new_session=True)
        # Wait (wall-clock bound, generous for a loaded machine) until it has the latched map.
        seen, deadline = [], time.monotonic() + 90.0
        while time.monotonic() < deadline:
            line = auto.stdout.readline()
            if not line:
                break
            seen.append(line)
            if "first map received" in line:
                break
        assert any("first map received" in l for l in seen), "".join(seen)
        assert not (tmp_path / "auto.yaml").exists()  # well before the first interval
        os.killpg(auto.pid, signal.SIGINT)
        rest, _ = auto.communicate(timeout=60)
        auto_out = "".join(seen) + rest
        assert "saved the map (at shutdown)" in auto_out, auto_out
    finally:
        os.killpg(server.pid, signal.SIGINT)
        try:
            server.wait(timeout=20)
        except subprocess.TimeoutExpired:
            os.killpg(server.pid, signal.SIGKILL)
    expected = load_map(COMMITTED_MAP)
    for name in ("saved", "auto"):
        got = load_map(str(tmp_path / f"{name}.yaml"))
        np.testing.assert_array_equal(got.data, expected.data)
        np.testing.assert_allclose(got.origin, expected.origin, atol=1e-6)
        assert got.resolution == expected.resolution


SCAN_FEEDER = r'''
"""Feeds slam_gmapping bad input: scans before the laser tf exists, NaN/inf ranges, a
changed beam count, then good scans; prints GOT MAP when a map arrives."""
import math, sys, threading, time
import rospy, tf2_ros
from geometry_msgs.msg import TransformStamped
from nav_msgs.msg import OccupancyGrid
from sensor_msgs.msg import LaserScan

rospy.init_node("scan_feeder")
scan_pub = rospy.Publisher("/scan", LaserScan, queue_size=10)
tf_pub = tf2_ros.TransformBroadcaster()
static_pub = tf2_ros.StaticTransformBroadcaster()
got = []
rospy.Subscriber("/map", OccupancyGrid, lambda m: got.append(m))

def odom_loop():
    while not rospy.is_shutdown():
        t = TransformStamped()
        t.header.stamp = rospy.Time.now()
        t.header.frame_id, t.child_frame_id = "odom", "base_footprint"
        t.transform.rotation.w = 1.0
        tf_pub.sendTransform(t)
        time.sleep(0.01)
threading.Thread(target=odom_loop, daemon=True).start()

def scan(n, bad=False):
    s = LaserScan()
    s.header.stamp = rospy.Time.now() - rospy.Duration(0.05)
    s.header.frame_id = "laser"
    s.angle_min, s.angle_increment = -math.pi / 2, math.pi / (n - 1)
    s.angle_max = math.pi / 2
    s.range_min, s.range_max = 0.1, 30.0
    # a square room 4 m x 4 m around the laser
    s.ranges = [min(2.0 / max(abs(math.cos(s.angle_min + k * s.angle_increment)), 1e-9),
                    2.0 / max(abs(math.sin(s.angle_min + k * s.angle_increment)), 1e-9)) for k in range(n)]
    if bad:
        s.ranges[::7] = [float("nan")] * len(s.ranges[::7])
        s.ranges[3::7] = [float("inf")] * len(s.ranges[3::7])
    scan_pub.publish(s)
    time.sleep(0.05)

time.sleep(1.0)
for _ in range(10):
    scan(181)                       # no tf base_footprint <- laser yet
t = TransformStamped()
t.header.stamp = rospy.Time.now()
t.header.frame_id, t.child_frame_id = "base_footprint", "laser"
t.transform.translation.x = 0.2
t.transform.rotation.w = 1.0
static_pub.sendTransform(t)
time.sleep(0.5)
for _ in range(20):
    scan(181, bad=True)             # NaN and inf readings
for _ in range(5):
    scan(90)                        # the beam count changes
end = time.time() + 15.0
while not got and time.time() < end:
    scan(181)
print("GOT MAP" if got else "NO MAP", flush=True)
'''


@pytest.mark.integration
def test_slam_gmapping_survives_bad_scans(tmp_path):
    """Missing laser tf, NaN/inf ranges, a changed beam count: warnings, no crash, a map."""
    feeder = tmp_path / "feeder.py"
    feeder.write_text(SCAN_FEEDER)
    slam = None
    # wall-clock bounds generous under load
    with Roscore(env=env_for(tmp_path, 0), timeout=90.0, caller="/test_bad_scans") as core:
        env, master = core.env, core.master
        try:
            slam = subprocess.Popen(["rosrun", "my_summit_mapping", "slam_gmapping", "_base_frame:=base_footprint",
                                     "_map_update_interval:=0.5", "_particles:=5", "_xmin:=-5", "_ymin:=-5",
                                     "_xmax:=5", "_ymax:=5"], stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                    text=True, env=env, start_new_session=True)
            wait_for(lambda: any(t == "/scan" for t, _ in master.getSystemState()[1]), 90.0,
                     "slam_gmapping to subscribe to /scan", core, poll=0.2)
            _, code, out = run(["/usr/bin/python3", str(feeder)], env)
            assert "GOT MAP" in out, out[-3000:]
            assert slam.poll() is None, "slam_gmapping died"
        finally:
            stop_process_tree(slam, grace=15.0)
    log = slam.stdout.read()
    assert "no tf base_footprint <- laser for the laser mount yet" in log, log[-3000:]
    assert "the laser changed from" in log and "181" in log and "90" in log, log[-3000:]
    assert "Traceback" not in log, log[-3000:]
