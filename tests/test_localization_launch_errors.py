"""amcl's parameters at launch: a bad value ends amcl.launch at once, naming the parameter
and why; a name amcl does not read is named once and amcl runs on, as the real one does."""
import os

import pytest

from summit_nav_common.testing.roslaunch_session import free_port, run_bounded

TIMEOUT = 60  # [s]


def launch(tmp_path, params_text, timeout=TIMEOUT):
    """Run amcl.launch (no simulator) with a parameter file; (returncode or None if still
    running after timeout [s], output)."""
    params = tmp_path / "amcl_params.yaml"
    params.write_text(params_text)
    port = free_port()
    env = dict(os.environ, ROS_MASTER_URI=f"http://127.0.0.1:{port}", ROS_LOG_DIR=str(tmp_path / "log"),
               ROS_HOME=str(tmp_path))
    rc, out = run_bounded(["roslaunch", "-p", str(port), "my_summit_localization", "amcl.launch",
                           f"params:={params}"], env, timeout)
    return rc, out


def launch_failing(tmp_path, params_text):
    """launch(), which must end at once with amcl, the required node; the output."""
    rc, out = launch(tmp_path, params_text)
    if rc is None:
        pytest.fail(f"amcl.launch with {params_text!r} still running after {TIMEOUT} s:\n{out[-3000:]}")
    assert "REQUIRED process [amcl" in out, out[-3000:]
    return out


@pytest.mark.integration
def test_a_name_amcl_does_not_read_is_named_and_amcl_runs(tmp_path):
    """jackal_navigation's amcl.launch sets receive_map_topic, which amcl has never read:
    the real amcl runs with it, and so must ours (here with the course map and no scans)."""
    rc, out = launch(tmp_path, "laser_z_hitt: 0.5\nreceive_map_topic: true\n", timeout=20)
    assert rc is None, f"amcl.launch ended (rc {rc}):\n{out[-3000:]}"
    assert "'laser_z_hitt' is not a parameter this node reads; ignored (did you mean 'laser_z_hit'?)" in out, \
        out[-3000:]
    assert "'receive_map_topic' is not a parameter this node reads; ignored" in out, out[-3000:]


@pytest.mark.integration
def test_bad_amcl_values_are_named(tmp_path):
    out = launch_failing(tmp_path, "min_particles: 500\nmax_particles: 100\n")
    assert "'max_particles' = 100: must be >= min_particles (500)" in out, out[-3000:]
    out = launch_failing(tmp_path, "laser_model_type: beams\n")
    assert "'laser_model_type' = 'beams': must be one of" in out, out[-3000:]
