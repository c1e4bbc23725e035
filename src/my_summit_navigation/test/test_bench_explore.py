"""bench_explore.py's launch prefix that runs another SLAM node in ours' place: roslaunch
calls PREFIX OUR_NODE ARGS...; the prefix runs NODE ARGS... in the environment the setup
file adds."""
import importlib.util
import os
import subprocess

HERE = os.path.dirname(os.path.abspath(__file__))


def _load():
    path = os.path.join(HERE, "..", "scripts", "bench_explore.py")
    spec = importlib.util.spec_from_file_location("bench_explore", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_prefix_runs_the_other_node_with_the_launch_arguments(tmp_path):
    node = tmp_path / "real node"            # a space in the path: quoted
    node.write_text('#!/bin/bash\necho "$PEER_ENV|$*"\n')
    node.chmod(0o755)
    setup = tmp_path / "setup.bash"
    setup.write_text('[ "$1" = --extend ] && export PEER_ENV=sourced\n')
    prefix = _load().node_prefix(str(tmp_path / "prefix.sh"), str(node), str(setup))
    out = subprocess.run([prefix, "/ws/devel/lib/my_summit_mapping/slam_karto", "__name:=slam_karto",
                          "scan:=/hokuyo_base/scan"], capture_output=True, text=True, check=True).stdout
    assert out == "sourced|__name:=slam_karto scan:=/hokuyo_base/scan\n"
    assert not os.path.exists(prefix + ".part")


def test_prefix_without_setup(tmp_path):
    prefix = _load().node_prefix(str(tmp_path / "prefix.sh"), "/bin/echo")
    out = subprocess.run([prefix, "ours", "a", "b"], capture_output=True, text=True, check=True).stdout
    assert out == "a b\n"
