"""my_summit_navigation without a ROS master: the command-line client refuses bad targets
(exit 2, naming the fault, nothing sent) and main.launch passes its arguments through."""
import os
import subprocess

WS = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
PKG = os.path.join(WS, "src", "my_summit_navigation")
CLIENT = os.path.join(PKG, "scripts", "send_coordinates_action_client.py")
PYTHON = "/usr/bin/python3"   # the ROS Python
TIMEOUT = 60                  # [s]
# a master URI nothing listens on: the client must fail before it would contact one
ENV = dict(os.environ, ROS_MASTER_URI="http://127.0.0.1:1")


def client(*args):
    p = subprocess.run([PYTHON, CLIENT, *args], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                       timeout=TIMEOUT, env=ENV)
    return p.returncode, p.stdout


def test_unknown_label_lists_the_known_ones():
    rc, out = client("kitchen")
    assert rc == 2, out
    assert "unknown label 'kitchen'; known labels: room, turtle, table" in out


def test_bad_targets_exit_2_with_the_reason(tmp_path):
    for args, why in [(("1.0", "2.0"), "expected a label or x y yaw, got 2"),
                      (("1.0", "north", "0"), "must be numbers"),
                      (("1.0", "inf", "0"), "finite"),
                      (("",), "empty")]:
        rc, out = client(*args)
        assert rc == 2, out
        assert why in out, out
    missing = tmp_path / "none" / "spots.txt"
    rc, out = client("room", "--spots-file", str(missing))
    assert rc == 2 and str(missing) in out and "cannot read the spots file" in out, out
    bad = os.path.join(PKG, "test", "data", "malformed_spots.yaml")
    rc, out = client("room", "--spots-file", bad)
    assert rc == 2 and bad in out and "malformed YAML" in out, out


def test_help_names_both_forms():
    rc, out = client("--help")
    assert rc == 0 and "LABEL | X Y YAW" in out


def dump_params(*args):
    p = subprocess.run(["roslaunch", "--dump-params", "my_summit_navigation", "main.launch", *args],
                       stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=TIMEOUT, env=ENV)
    assert p.returncode == 0, p.stdout
    return p.stdout


def test_main_launch_passes_its_arguments_through():
    out = dump_params("sim:=true", "speed:=3.0", "seed:=7", "initial_pose_x:=1.5", "initial_pose_a:=0.5",
                      "spots_file:=/tmp/spots.txt", "server_timeout:=4.0", "goal_timeout:=60.0")
    for line in ["/get_coordinates_service_server/spots_file: /tmp/spots.txt",
                 "/get_coordinates_service_server/server_timeout: 4.0",
                 "/get_coordinates_service_server/goal_timeout: 60.0",
                 "/get_coordinates_service_server/move_base_action: move_base",
                 "/amcl/initial_pose_x: 1.5", "/amcl/initial_pose_a: 0.5",
                 "/summit_xl_sim/speed: 3.0", "/summit_xl_sim/seed: 7"]:
        assert line in out, line
    assert "/move_base/" in out
    default = dump_params()
    assert "/summit_xl_sim/" not in default      # sim:=false: no simulator
    assert "my_summit_localization/config/spots.yaml" in default


def test_main_launch_documents_every_argument():
    p = subprocess.run(["roslaunch", "--ros-args", "my_summit_navigation", "main.launch"],
                       stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=TIMEOUT, env=ENV)
    assert p.returncode == 0, p.stdout
    for arg in ["sim", "speed", "gui", "seed", "map_file", "initial_pose_x", "initial_pose_y", "initial_pose_a",
                "spots_file", "server_timeout", "goal_timeout"]:
        assert f"  {arg} (default" in p.stdout, arg
    assert "undocumented" not in p.stdout
