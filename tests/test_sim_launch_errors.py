"""Bad input at launch: the simulator fails at once, naming the file or pose and why."""
import os
import time

import pytest

from summit_nav_common.testing.roslaunch_session import free_port, run_bounded

TIMEOUT = 60  # [s]


def launch(tmp_path, *args):
    """Run sim.launch with args on a private master; returns (seconds, output)."""
    port = free_port()
    env = dict(os.environ, ROS_MASTER_URI=f"http://127.0.0.1:{port}", ROS_LOG_DIR=str(tmp_path / "log"),
               ROS_HOME=str(tmp_path))
    t0 = time.monotonic()
    rc, out = run_bounded(["roslaunch", "-p", str(port), "summit_xl_sim", "sim.launch", *args], env, TIMEOUT)
    if rc is None:
        pytest.fail(f"launch with {args} still running after {TIMEOUT} s:\n{out[-3000:]}")
    return time.monotonic() - t0, out


@pytest.mark.integration
def test_missing_world_file(tmp_path):
    secs, out = launch(tmp_path, f"world:={tmp_path}/nowhere.yaml")
    assert "nowhere.yaml: map YAML does not exist" in out, out[-3000:]
    assert "REQUIRED process [summit_xl_sim" in out


@pytest.mark.integration
def test_malformed_world_and_missing_image(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("image: gone.pgm\nresolution: 0.05\norigin: [0, 0, 0]\nnegate: 0\n"
                   "occupied_thresh: 0.65\nfree_thresh: 0.196\n")
    _, out = launch(tmp_path, f"world:={bad}")
    assert "gone.pgm does not exist" in out, out[-3000:]
    bad.write_text("image: [oops\n")
    _, out = launch(tmp_path, f"world:={bad}")
    assert "malformed YAML" in out, out[-3000:]


@pytest.mark.integration
def test_spawn_in_wall_and_off_map(tmp_path):
    _, out = launch(tmp_path, "x:=12.0", "y:=6.0")
    assert "cannot spawn" in out and "overlaps a wall" in out, out[-3000:]
    _, out = launch(tmp_path, "x:=80.0", "y:=6.0")
    assert "off the map" in out, out[-3000:]


@pytest.mark.integration
def test_bad_odom_model_and_imu_rate(tmp_path):
    _, out = launch(tmp_path, "odom_model:=slippery")
    assert "~odom_model must be one of ideal, skid" in out and "REQUIRED process [summit_xl_sim" in out, out[-3000:]
    _, out = launch(tmp_path, "drive:=omni", "odom_model:=skid")
    assert "odom_model skid is the skid-steer base's; drive omni" in out, out[-3000:]
    _, out = launch(tmp_path, "imu_rate:=0")
    assert "~imu_rate must be > 0" in out, out[-3000:]
