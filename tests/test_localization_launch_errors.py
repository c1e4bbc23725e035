"""Bad amcl parameters at launch: amcl.launch ends at once, naming the parameter and why."""
import os
import sys

import pytest

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "tools"))
from roslaunch_session import free_port, run_bounded  # noqa: E402

TIMEOUT = 60  # [s]


def launch(tmp_path, params_text):
    """Run amcl.launch (no simulator) with a parameter file; returns the output."""
    params = tmp_path / "amcl_params.yaml"
    params.write_text(params_text)
    port = free_port()
    env = dict(os.environ, ROS_MASTER_URI=f"http://127.0.0.1:{port}", ROS_LOG_DIR=str(tmp_path / "log"),
               ROS_HOME=str(tmp_path))
    rc, out = run_bounded(["roslaunch", "-p", str(port), "my_summit_localization", "amcl.launch",
                           f"params:={params}"], env, TIMEOUT)
    if rc is None:
        pytest.fail(f"amcl.launch with {params_text!r} still running after {TIMEOUT} s:\n{out[-3000:]}")
    assert "REQUIRED process [amcl" in out, out[-3000:]
    return out


@pytest.mark.integration
def test_unknown_amcl_parameter_is_named_with_a_suggestion(tmp_path):
    out = launch(tmp_path, "laser_z_hitt: 0.5\n")
    assert "unknown amcl parameter 'laser_z_hitt' (did you mean 'laser_z_hit'?)" in out, out[-3000:]


@pytest.mark.integration
def test_bad_amcl_values_are_named(tmp_path):
    out = launch(tmp_path, "min_particles: 500\nmax_particles: 100\n")
    assert "'max_particles' = 100: must be >= min_particles (500)" in out, out[-3000:]
    out = launch(tmp_path, "laser_model_type: beams\n")
    assert "'laser_model_type' = 'beams': must be one of" in out, out[-3000:]
