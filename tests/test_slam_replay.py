"""bench_slam_replay.py: the real gmapping's seeded player read back (its debug log, the
online estimate made from its updates), the bag it reads, and its bad input."""
import math
import os
import subprocess
import sys

import numpy as np
import pytest

WS = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SCRIPTS = os.path.join(WS, "src", "my_summit_mapping", "scripts")
RUNNER = os.path.join(SCRIPTS, "bench_slam_replay.py")
INTEL = os.path.join(WS, "data", "carmen", "intel-corrected.log.gz")


def test_player_log_gives_each_best_pose_the_scan_of_its_update():
    """The player prints "update frame N" (GridSlamProcessor, stdout) before the node's
    ROS_DEBUG "new best pose" (coloured by rosconsole); other lines interleave."""
    import bench_slam_replay as bsr
    text = ("update frame 0\nLaser Pose= 0.9 -0.2 -0.46\nRegistering First Scan\n"
            "\x1b[32mnew best pose: 0.897 -0.181 -0.463\x1b[0m\n\x1b[32m  21.917 -32.728 -1.477\x1b[0m\n"
            "update frame 3\nupdate ld=0.2 ad=0.1\nneff= 29\n*************RESAMPLE***************\n"
            "\x1b[32mnew best pose: 1.000 -2.500 3.100\x1b[0m\n")
    frames, poses = bsr.parse_player_log(text)
    assert frames.tolist() == [0, 3]
    assert poses.tolist() == [[0.897, -0.181, -0.463], [1.0, -2.5, 3.1]]
    with pytest.raises(ValueError, match="debug output"):
        bsr.parse_player_log("update frame 0\n")
    with pytest.raises(ValueError, match="before any 'update frame'"):
        bsr.parse_player_log("new best pose: 1 2 3\n")


def test_online_estimate_from_updates_holds_each_correction_until_the_next_update():
    """The node tracks a laser frame turned by c against the base. At an update the online
    estimate is the best pose (turned back to the base); until the next update it is that
    update's correction (map -> odom) applied to the odometry, which drifts on meanwhile;
    before the first update, the odometry."""
    import bench_slam_replay as bsr
    from summit_nav_common.geometry import compose, inverse
    rng = np.random.default_rng(3)
    truth = np.cumsum(rng.normal(0.0, 0.3, (12, 3)), axis=0)
    odom = compose(np.cumsum(rng.normal(0.0, 0.05, (12, 3)), axis=0), truth)   # drift grows per scan
    c = math.radians(-0.5)
    frames = np.array([2, 5, 9])
    best = compose(truth[frames], np.array([0.0, 0.0, c]))
    online = bsr.online_from_updates(frames, best, odom, c)
    np.testing.assert_allclose(online[frames], truth[frames], atol=1e-12)
    correction = compose(truth[5], inverse(odom[5]))                  # map -> odom after scan 5's update
    np.testing.assert_allclose(online[6:9], compose(correction, odom[6:9]), atol=1e-12)
    assert np.abs(online[6:9, :2] - truth[6:9, :2]).max() > 0.01        # the drift since scan 5 shows
    np.testing.assert_allclose(online[:2], odom[:2], atol=1e-12)


def test_bag_for_the_player_carries_the_laser_mount_in_tf(tmp_path):
    """slam_gmapping_replay reads /tf and /scan only, so base_link -> base_laser goes into
    every /tf message as well; the bag reads back as the plain one."""
    import rosbag
    from my_summit_mapping import carmen, carmen_bag
    scans = carmen_bag.bag_scans(carmen.read_carmen(INTEL), seed=1)
    scans = carmen_bag.BagScans(**{**scans.__dict__, "stamps": scans.stamps[:4], "ranges": scans.ranges[:4],
                                   "odometry": scans.odometry[:4], "reference": scans.reference[:4],
                                   "laser_offset": 0.25})
    plain, mounted = str(tmp_path / "plain.bag"), str(tmp_path / "mounted.bag")
    carmen_bag.write_bag(scans, plain)
    carmen_bag.write_bag(scans, mounted, mount_in_tf=True)
    with rosbag.Bag(mounted) as bag:
        tfs = [m for _t, m, _s in bag.read_messages(topics=["/tf"])]
    assert len(tfs) == 4
    for msg in tfs:
        pairs = {(t.header.frame_id, t.child_frame_id): t for t in msg.transforms}
        mount = pairs[("base_link", "base_laser")]
        assert mount.transform.translation.x == 0.25 and mount.header.stamp == pairs[("odom", "base_link")].header.stamp
    a, b = carmen_bag.read_bag(plain), carmen_bag.read_bag(mounted)
    np.testing.assert_array_equal(a.odometry, b.odometry)
    assert a.laser_offset == b.laser_offset == 0.25


@pytest.mark.parametrize("args, expect", [
    ([INTEL, "--replay", "/no/such/player"], "--replay /no/such/player: not an executable file"),
    ([INTEL, "--replay", "/bin/true", "--setup", "/no/such/setup.bash"], "--setup /no/such/setup.bash: no such file"),
    (["/no/such/log.gz", "--replay", "/bin/true"], "/no/such/log.gz"),
])
def test_runner_bad_input_fails_with_the_reason(args, expect):
    proc = subprocess.run([sys.executable, RUNNER] + args, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                          text=True, timeout=120)
    assert proc.returncode == 2 and expect in proc.stdout, proc.stdout


def test_replay_with_the_real_nodes_conventions_moves_cells_and_beams_as_it_does():
    """slam_bag_offline.py --as-gmapping: the real node's beams start half an increment
    before the scan's angle_min (GMapping::RangeSensor: -n/2 increments from the centre), its
    cell borders lie at its map centre + delta/2 modulo delta (world2map rounds from the
    centre); ours are at multiples of delta, so the odometry moves by the difference."""
    import slam_bag_offline
    from my_summit_mapping import carmen, carmen_bag
    scans = carmen_bag.bag_scans(carmen.read_carmen(INTEL), seed=1)
    params = dict(delta=0.05, xmin=-27.0, xmax=29.0, ymin=-45.0, ymax=6.2)   # centre (1.0, -19.4)
    moved, angles = slam_bag_offline.as_gmapping(scans, params)
    shift = moved.odometry - scans.odometry
    # a border of the real node's: centre + delta/2 (+ k delta); after the shift it is a multiple of delta
    for axis, centre in ((0, 1.0), (1, -19.4)):
        border = centre + 0.025 + 0.05 * 7
        moved_border = border + shift[0, axis]
        assert abs(moved_border / 0.05 - round(moved_border / 0.05)) < 1e-9
        assert -0.05 < shift[0, axis] <= 0.0
    assert np.all(shift[:, 2] == 0.0)
    np.testing.assert_allclose(shift[:, :2], np.tile(shift[0, :2], (len(shift), 1)), atol=1e-12)
    np.testing.assert_allclose(angles, slam_bag_offline.beam_angles(scans) - 0.5 * scans.angle_increment)
    assert angles[0] == pytest.approx(math.radians(-90.5))
