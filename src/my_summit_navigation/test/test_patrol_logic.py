"""Unit tests of the patrol's decisions (my_summit_navigation.cruise)."""
import math

from my_summit_navigation import cruise as pl
from my_summit_navigation.spot_goals import SpotBook

SPOTS = """frame_id: map
spots:
  room: {position: {x: 14.0, y: -3.5, z: 0.0}, orientation: {x: 0, y: 0, z: 0, w: 1}}
  table: {position: {x: 13.8, y: -1.8, z: 0.0}, orientation: {x: 0, y: 0, z: 1, w: 0}}
"""


def test_labels_from_a_spots_file_keep_unknown_ones_with_the_reason(tmp_path):
    path = tmp_path / "spots.yaml"
    path.write_text(SPOTS)
    stops = pl.build_stops(labels=["table", "ghost", "room"], book=SpotBook(path))
    assert [s.name for s in stops] == ["table", "ghost", "room"]
    assert stops[0].spot.x == 13.8 and stops[0].error is None
    assert stops[1].spot is None and "unknown label 'ghost'" in stops[1].error and "room" in stops[1].error
    assert stops[2].frame == "map"


def test_a_missing_spots_file_makes_every_label_a_reported_skip(tmp_path):
    stops = pl.build_stops(labels=["room"], book=SpotBook(tmp_path / "nope.yaml"))
    assert stops[0].spot is None and "nope.yaml" in stops[0].error


def test_poses_in_both_forms_and_bad_ones():
    stops = pl.build_stops(poses=[[1.0, 2.0, 90.0], {"name": "dock", "x": 0, "y": 0, "yaw_deg": 0},
                                  [1.0, "a", 0], [1.0, 2.0], [float("nan"), 0, 0]], frame="map")
    assert stops[0].name == "pose 1" and math.isclose(stops[0].spot.yaw, math.pi / 2)
    assert stops[1].name == "dock" and stops[1].error is None
    assert all(s.spot is None and "bad pose" in s.error for s in stops[2:])


def test_decide_retries_then_skips_with_the_reason():
    assert pl.decide(pl.SUCCEEDED, "", 1, 2) == (pl.NEXT, "reached")
    action, why = pl.decide(pl.ABORTED, "goal in an obstacle", 1, 2)
    assert action == pl.RETRY and "goal in an obstacle" in why
    assert pl.decide(pl.ABORTED, "x", 2, 2)[0] == pl.RETRY
    action, why = pl.decide(pl.ABORTED, "goal in an obstacle", 3, 2)
    assert action == pl.SKIP and "after 3 tries" in why and "goal in an obstacle" in why
    assert pl.decide(pl.PREEMPTED, "", 1, 0, stuck=True)[0] == pl.SKIP
    assert "stuck" in pl.decide(pl.PREEMPTED, "", 1, 1, stuck=True)[1]


def test_progress_watch_says_stuck_only_without_progress():
    w = pl.ProgressWatch(stuck_timeout=10.0, min_progress=0.1)
    w.reset(0.0)
    assert not w.update(5.0, 0.0)
    assert not w.update(4.0, 8.0)      # progress: the clock restarts
    assert not w.update(3.95, 17.0)    # < 0.1 m better, 9 s since the last progress
    assert w.update(3.95, 18.5)        # 10.5 s without 0.1 m of progress
    w.reset(20.0)
    assert not w.update(3.95, 20.0)
    assert not pl.ProgressWatch(stuck_timeout=0.0).update(1.0, 1e9)  # 0: never stuck


def test_log_lines_and_summary():
    log = pl.PatrolLog()
    stop = pl.Stop("in_desk")
    assert "reached" in log.goal_line(1, pl.Stop("room"), pl.NEXT, "reached", 12.0)
    assert "retrying" in log.goal_line(1, stop, pl.RETRY, "move_base aborted: blocked", 0.2)
    assert "SKIPPED" in log.goal_line(1, stop, pl.SKIP, "move_base aborted: blocked (after 2 tries)", 0.2)
    text = log.summary(1, 60.0)
    assert "reached 1, retried 1, skipped 1" in text and "'in_desk' (move_base aborted: blocked (after 2 tries))" in text
