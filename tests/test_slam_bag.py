"""The live slam_gmapping node on real laser data: the first minute of the CARMEN Intel log
played from a rosbag (bench_slam_bag.py: roscore, the node, rosbag play --clock), and the
runner's refusal of bad input."""
import json
import os
import re
import subprocess
import sys

import pytest

WS = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
RUNNER = os.path.join(WS, "src", "my_summit_mapping", "scripts", "bench_slam_bag.py")
INTEL = os.path.join(WS, "data", "carmen", "intel-corrected.log.gz")
SLICE_S = 60.0       # [s of log] the first minute: the robot leaves the first room
RATE = 2.0           # rosbag play rate
ATE_BOUND = 0.30     # [m] the full-log benchmark is ~0.1 m; the drifted odometry here ~0.2-0.5 m
TIMEOUT = 600        # [s wall]


@pytest.mark.integration
def test_live_node_maps_the_first_minute_of_intel(tmp_path):
    out = tmp_path / "out"
    res_path = tmp_path / "res.json"
    proc = subprocess.run([sys.executable, RUNNER, INTEL, "--seeds", "1", "--duration", str(SLICE_S),
                           "--rate", str(RATE), "--out", str(out), "--json", str(res_path)],
                          stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=TIMEOUT)
    assert proc.returncode == 0, proc.stdout[-4000:]
    res = json.loads(res_path.read_text())
    run = res["runs"][0]
    assert run["scans"] >= 10 and run["reference_poses_received"] == run["scans"]
    assert run["updates"] > 0 and run["updates"] >= run["expected_updates"] - 2, run
    assert run["ate_online_m"] < ATE_BOUND, run
    assert run["maps_received"] >= 1 and os.path.getsize(run["png"]) > 0
    assert run["cpu_s"] > 0.0 and run["peak_rss_mb"] > 50.0


@pytest.mark.parametrize("args, expect", [
    (["/no/such/log.gz"], "/no/such/log.gz: no such file"),
    ([INTEL, "--rate", "0"], "--rate must be a finite number > 0"),
    ([INTEL, "--set", "particles"], "--set expects name=value"),
    ([INTEL, "--node", "/no/such/slam_gmapping"], "--node /no/such/slam_gmapping: not an executable file"),
    ([INTEL, "--node", INTEL], f"--node {INTEL}: not an executable file"),
    ([INTEL, "--node-setup", "/opt/ros/noetic/setup.bash"], "--node-setup needs --node"),
    ([INTEL, "--node", "/bin/true", "--node-setup", "/no/setup.bash"], "--node-setup /no/setup.bash: no such file"),
])
def test_runner_bad_input_fails_with_the_reason(args, expect):
    proc = subprocess.run([sys.executable, RUNNER] + args, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                          text=True, timeout=60)
    assert proc.returncode == 2 and expect in proc.stderr, proc.stderr


def test_runner_on_a_file_that_is_not_carmen_names_it(tmp_path):
    bad = tmp_path / "notes.log"
    bad.write_text("hello\n")
    proc = subprocess.run([sys.executable, RUNNER, str(bad), "--out", str(tmp_path / "o")], stdout=subprocess.PIPE,
                          stderr=subprocess.PIPE, text=True, timeout=60)
    assert proc.returncode == 2 and f"{bad}: no FLASER lines" in proc.stderr, proc.stderr


def test_node_parameters_follow_the_evaluation_settings():
    import numpy as np
    import bench_slam_bag
    from my_summit_mapping.carmen_bag import BagScans

    ref = np.array([[-3.2, 1.0, 0.0], [10.5, -20.1, 1.0]])
    scans = BagScans(stamps=np.array([0.0, 1.0]), ranges=np.ones((2, 180)), angle_min=-1.57, angle_increment=0.017,
                     range_max=81.83, odometry=ref, reference=ref, laser_offset=0.0, seed=0, stamps_moved=0)
    p = bench_slam_bag.node_params(scans)
    assert (p["particles"], p["delta"], p["linearUpdate"], p["angularUpdate"]) == (30, 0.05, 0.2, 0.1)
    assert p["maxUrange"] == 50.0 and p["maxRange"] == pytest.approx(81.84)
    assert (p["xmin"], p["ymin"], p["xmax"], p["ymax"]) == (-9.0, -26.0, 16.0, 6.0)
    scans.range_max = 30.0
    p = bench_slam_bag.node_params(scans, {"particles": 5})
    assert p["maxUrange"] == pytest.approx(29.99) and p["maxRange"] == pytest.approx(30.01) and p["particles"] == 5


def test_another_node_runs_directly_in_the_environment_its_setup_file_leaves(tmp_path):
    import bench_slam_bag
    from summit_nav_common.testing.roslaunch_session import sourced_env

    ours = bench_slam_bag.node_command()
    assert ours[0] == sys.executable and ours[1].endswith(os.path.join("nodes", "slam_gmapping"))
    assert ours[-1] == "__name:=slam_gmapping"
    assert bench_slam_bag.node_command("/ws/devel/lib/gmapping/slam_gmapping") == [
        "/ws/devel/lib/gmapping/slam_gmapping", "__name:=slam_gmapping"]
    setup = tmp_path / "setup.bash"
    setup.write_text('echo sourcing\nexport LD_LIBRARY_PATH="/ws/devel/lib:$LD_LIBRARY_PATH"\n'
                     'export MULTI="a\nb=c"\nunset DROPPED\n')
    env = sourced_env(str(setup), {"PATH": os.environ["PATH"], "LD_LIBRARY_PATH": "/opt/lib",
                                   "DROPPED": "1", "ROS_MASTER_URI": "http://127.0.0.1:1"})
    assert env["LD_LIBRARY_PATH"] == "/ws/devel/lib:/opt/lib" and env["MULTI"] == "a\nb=c"
    assert env["ROS_MASTER_URI"] == "http://127.0.0.1:1" and "DROPPED" not in env
    setup.write_text("return 3\n")
    with pytest.raises(ValueError, match=f"--node-setup {setup}: sourcing it failed \\(exit status 3\\)"):
        sourced_env(str(setup), {"PATH": os.environ["PATH"]})


def test_another_nodes_updates_are_counted_from_its_log_or_not_known(tmp_path):
    """The real gmapping prints "update frame N" at each filter update (N: scans received);
    its stderr interleaves (the second update's line follows a tf warning)."""
    import bench_slam_bag

    log = tmp_path / "node.log"
    log.write_text("Registering First Scan\nupdate frame 0\nupdate ld=0 ad=0\nLaser Pose= 1 2 0.5\n"
                   "Warning: TF_REPEATED_DATA ignoring data\nWarning: update frame 3\nupdate ld=0.21 ad=0\n"
                   "neff= 29.5\nupdate frame 4\n")
    assert bench_slam_bag.node_log_updates(str(log)) == 3
    log.write_text("[ INFO] slam_gmapping started\n")
    assert bench_slam_bag.node_log_updates(str(log)) is None
    run = dict(ate_online_m=0.4, ate_odom_m=3.7, cpu_s=50.0, peak_rss_mb=120.0, expected_updates=440)
    med, worst = bench_slam_bag.summarize([dict(run, updates=None, cpu_ms_per_update=None)] * 2)
    assert med["updates"] is None and worst["cpu_ms_per_update"] is None and med["ate_online_m"] == 0.4
    med, worst = bench_slam_bag.summarize([dict(run, updates=430, cpu_ms_per_update=116.0),
                                           dict(run, updates=420, cpu_ms_per_update=119.0)])
    assert (med["updates"], worst["updates"], worst["cpu_ms_per_update"]) == (425, 420, 119.0)
    assert bench_slam_bag.known(None, "9.1f") == "      n/a" and bench_slam_bag.known(1.5, "9.1f") == "      1.5"


def test_offline_replay_of_a_log_feeds_the_filter_what_the_node_gets_from_its_bag(tmp_path):
    """slam_bag_offline.py on a CARMEN log gives the filter the scans, odometry and beam
    angles the node gets from the log's bag, bit for bit: the filter is chaotic, and on
    the log's own float64 values ACES seed 1 ended at an online ATE of 0.868 m where the
    live run (and the replay of its bag) gave 0.422 m."""
    import numpy as np
    import slam_bag_offline
    from my_summit_mapping import carmen, carmen_bag, laser_mount
    from summit_nav_common.geometry import quaternion_matrix

    full = carmen.read_carmen(INTEL)
    log = carmen.CarmenLog(ranges=full.ranges[:60], angles=full.angles, poses=full.poses[:60],
                           timestamps=full.timestamps[:60], laser_offset=full.laser_offset)
    bag = str(tmp_path / "intel_first60.bag")
    carmen_bag.write_bag(carmen_bag.bag_scans(log, 2), bag)
    from_bag, from_log = slam_bag_offline.load_scans(bag, 2), slam_bag_offline.load_scans("intel.log.gz", 2, log)
    for name in ("stamps", "ranges", "odometry", "reference", "angle_min", "angle_increment", "range_max",
                 "laser_offset"):
        assert np.array_equal(getattr(from_log, name), getattr(from_bag, name)), name
    # the beam angles: as the node computes them from the level mount's rotation
    node = laser_mount.beam_angles_in_base(quaternion_matrix(0.0, 0.0, 0.0, 1.0), from_bag.angle_min,
                                           from_bag.angle_increment, from_bag.ranges.shape[1])
    assert np.array_equal(slam_bag_offline.beam_angles(from_log), node)


@pytest.mark.integration
def test_runner_reports_a_node_that_dies_and_stops_everything(tmp_path):
    import psutil
    before = {p.pid for p in psutil.process_iter()}
    proc = subprocess.run([sys.executable, RUNNER, INTEL, "--duration", "10", "--set", "particles=0",
                           "--out", str(tmp_path / "o")], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                          text=True, timeout=180)
    assert proc.returncode == 1
    assert "slam_gmapping ended (exit status 1)" in proc.stderr and "'particles'" in proc.stderr, proc.stderr
    # nothing it started is left: the master on its port, and any process whose environment points at it.
    # Not matched by the node's path: the other live test of this file, in the other xdist worker, runs the
    # same node at the same time (CI on 826c7f5 failed on that node, which belonged to the other test).
    roscore_log = (tmp_path / "o" / "slam_bag_seed1_roscore.log").read_text()
    port = re.search(r"ROS_MASTER_URI=http://[^:]+:(\d+)", roscore_log).group(1)
    left = []
    for p in psutil.process_iter(["pid", "cmdline"]):
        if p.pid in before:
            continue
        cmd = p.info["cmdline"] or []
        try:
            env_uri = p.environ().get("ROS_MASTER_URI", "")
        except (psutil.NoSuchProcess, psutil.AccessDenied, psutil.ZombieProcess):
            env_uri = ""
        if env_uri.rstrip("/").endswith(f":{port}") or ("-p" in cmd and port in cmd):
            left.append(cmd)
    assert not left, left
