"""Bad move_base parameters at launch: move_base.launch ends at once, naming the parameter."""
import os
import shutil

import pytest

from summit_nav_common.testing.roslaunch_session import free_port, run_bounded

WS = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

TIMEOUT = 60  # [s]
CONFIG = os.path.join(WS, "src", "my_summit_path_planning", "config")


def launch(tmp_path, file_name, old, new):
    """Run move_base.launch alone (no simulator, no amcl) with one config file edited."""
    cfg = tmp_path / "config"
    shutil.copytree(CONFIG, cfg)
    text = (cfg / file_name).read_text()
    assert old in text, f"{old!r} not in {file_name}"
    (cfg / file_name).write_text(text.replace(old, new, 1))
    port = free_port()
    env = dict(os.environ, ROS_MASTER_URI=f"http://127.0.0.1:{port}", ROS_LOG_DIR=str(tmp_path / "log"),
               ROS_HOME=str(tmp_path))
    rc, out = run_bounded(["roslaunch", "-p", str(port), "my_summit_path_planning", "move_base.launch",
                           "localization:=false", f"config_dir:={cfg}"], env, TIMEOUT)
    if rc is None:
        pytest.fail(f"move_base.launch still running after {TIMEOUT} s:\n{out[-3000:]}")
    assert "REQUIRED process [move_base" in out, out[-3000:]
    return out


@pytest.mark.integration
def test_bad_move_base_value_is_named(tmp_path):
    out = launch(tmp_path, "move_base_params.yaml", "planner_patience: 5.0", "planner_patience: soon")
    assert "/move_base: 'planner_patience' must be float, got 'soon'" in out, out[-3000:]


@pytest.mark.integration
def test_bad_planner_and_costmap_values_are_named(tmp_path):
    out = launch(tmp_path, "dwa_local_planner_params.yaml", "sim_time: 1.7", "sim_time: -1.0")
    assert "DWAPlannerROS: 'sim_time' must be > 0, got -1.0" in out, out[-3000:]
    out = launch(tmp_path / "b", "local_costmap_params.yaml", "resolution: 0.05", "resolution: fine")
    assert "local_costmap: 'resolution' must be float, got 'fine'" in out, out[-3000:]
