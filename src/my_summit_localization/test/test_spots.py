"""Unit tests of the spot store, the spots YAML schema and the atomic write (no ROS)."""
import math
import os

import pytest

from my_summit_localization.spots import (END_LABEL, Spot, SpotRecorder, SpotsError, load_spots,
                                          parse_spots, spots_to_yaml, write_atomic)

PKG = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SPAWN = (2.0, 7.0)  # the committed map's origin in the simulator's world [m]
WORLD_SPOTS = {"room": (16.0, 3.5, 0.0), "turtle": (17.6, 1.3, -90.0), "table": (15.8, 5.2, 180.0)}


def test_committed_spots_are_the_world_spots_in_the_map_frame():
    frame, spots = load_spots(os.path.join(PKG, "config", "spots.yaml"))
    assert frame == "map"
    assert list(spots) == ["room", "turtle", "table"]
    for label, (wx, wy, yaw_deg) in WORLD_SPOTS.items():
        s = spots[label]
        assert s.x == pytest.approx(wx - SPAWN[0]) and s.y == pytest.approx(wy - SPAWN[1])
        assert math.cos(s.yaw - math.radians(yaw_deg)) == pytest.approx(1.0)


def test_yaml_round_trip_keeps_order_and_values():
    spots = {"b": Spot.from_xy_yaw(1.5, -2.0, 0.3), "a": Spot(0.1, 0.2, 0.0, 0.0, 0.0, 1.0, 0.0)}
    frame, back = parse_spots(spots_to_yaml(spots, "world", header="two\nlines"))
    assert frame == "world" and list(back) == ["b", "a"]
    assert back["b"] == spots["b"] and back["a"] == spots["a"]
    assert back["b"].yaw == pytest.approx(0.3)


@pytest.mark.parametrize("text, why", [
    ("spots: [oops", "malformed YAML"),
    ("- 1\n- 2\n", "'spots' key"),
    ("spots: {}\n", "non-empty mapping"),
    ("spots: {a: {position: {x: 1, y: 2}}}\n", "expected {position"),
    ("spots: {a: {position: {x: 1}, orientation: {x: 0, y: 0, z: 0, w: 1}}}\n", "missing y"),
    ("spots: {a: {position: {x: .nan, y: 0}, orientation: {x: 0, y: 0, z: 0, w: 1}}}\n", "finite"),
    ("spots: {a: {position: {x: 'one', y: 0}, orientation: {x: 0, y: 0, z: 0, w: 1}}}\n", "finite"),
    ("spots: {a: {position: {x: 0, y: 0}, orientation: {x: 0, y: 0, z: 0, w: 2}}}\n", "unit quaternion"),
    ("frame_id: ''\nspots: {a: {position: {x: 0, y: 0}, orientation: {x: 0, y: 0, z: 0, w: 1}}}\n", "frame_id"),
])
def test_malformed_spots_name_the_source_and_the_fault(text, why):
    with pytest.raises(SpotsError, match="f.yaml") as e:
        parse_spots(text, source="f.yaml")
    assert why in str(e.value)


def test_missing_file_is_a_clear_error(tmp_path):
    with pytest.raises(SpotsError, match="cannot read"):
        load_spots(tmp_path / "none.yaml")


def test_atomic_write_replaces_and_leaves_no_temp(tmp_path):
    p = tmp_path / "spots.txt"
    write_atomic(p, "one\n")
    write_atomic(p, "two\n")
    assert p.read_text() == "two\n"
    assert os.listdir(tmp_path) == ["spots.txt"]


def test_atomic_write_failure_keeps_the_old_file(tmp_path):
    p = tmp_path / "spots.txt"
    p.write_text("old\n")
    with pytest.raises(SpotsError, match="cannot write"):
        write_atomic(tmp_path / "missing_dir" / "spots.txt", "new\n")
    with pytest.raises(SpotsError, match="is a directory"):
        write_atomic(tmp_path, "new\n")
    if os.geteuid() != 0:  # root writes anywhere
        os.chmod(tmp_path, 0o500)
        try:
            with pytest.raises(SpotsError, match="cannot write"):
                write_atomic(p, "new\n")
        finally:
            os.chmod(tmp_path, 0o700)
    assert p.read_text() == "old\n"
    assert os.listdir(tmp_path) == ["spots.txt"]


def test_recorder_stores_replaces_and_writes(tmp_path):
    rec = SpotRecorder(str(tmp_path / "spots.txt"))
    ok, msg = rec.handle("room", Spot.from_xy_yaw(14.0, -3.5, 0.0))
    assert ok and "saved 'room'" in msg
    ok, msg = rec.handle(" turtle ", Spot.from_xy_yaw(15.6, -5.7, -math.pi / 2))
    assert ok and list(rec.spots) == ["room", "turtle"]
    ok, msg = rec.handle("room", Spot.from_xy_yaw(14.1, -3.4, 0.1))
    assert ok and "replaced" in msg and rec.spots["room"].x == pytest.approx(14.1)
    ok, msg = rec.handle(END_LABEL, None)  # 'end' needs no pose
    assert ok and "wrote 2 spots" in msg
    frame, spots = load_spots(tmp_path / "spots.txt")
    assert frame == "map" and list(spots) == ["room", "turtle"]
    assert spots["room"].x == pytest.approx(14.1) and spots["turtle"].yaw == pytest.approx(-math.pi / 2)


def test_recorder_refusals_store_nothing(tmp_path):
    path = tmp_path / "spots.txt"
    rec = SpotRecorder(str(path))
    for label in ("", "   "):
        ok, msg = rec.handle(label, Spot.from_xy_yaw(1, 2, 0))
        assert not ok and "label is empty" in msg
    ok, msg = rec.handle("room", None)
    assert not ok and "no pose yet" in msg
    ok, msg = rec.handle("room", Spot(float("nan"), 0.0))
    assert not ok and "finite" in msg
    assert not rec.spots
    ok, msg = rec.handle("end", None)
    assert not ok and "no spot stored" in msg and not path.exists()


def test_recorder_unwritable_path_keeps_the_earlier_file(tmp_path):
    good = tmp_path / "spots.txt"
    rec = SpotRecorder(str(good))
    rec.handle("room", Spot.from_xy_yaw(1, 2, 0))
    assert rec.handle("end", None)[0]
    before = good.read_text()
    rec.path = str(tmp_path / "no" / "such" / "dir" / "spots.txt")
    rec.handle("table", Spot.from_xy_yaw(3, 4, 0))
    ok, msg = rec.handle("end", None)
    assert not ok and "not saved" in msg and "no/such/dir" in msg
    assert good.read_text() == before
    assert list(rec.spots) == ["room", "table"]  # still there for a retry


def test_atomic_write_failing_rename_keeps_the_old_file(tmp_path, monkeypatch):
    """The write itself succeeds but the final rename fails (as on a full or read-only
    disk): the old file is untouched and the temporary file is removed."""
    p = tmp_path / "spots.txt"
    p.write_text("old\n")

    def fail(src, dst):
        raise PermissionError(13, "Permission denied")
    monkeypatch.setattr(os, "replace", fail)
    with pytest.raises(SpotsError, match="Permission denied"):
        write_atomic(p, "new\n")
    assert p.read_text() == "old\n"
    assert os.listdir(tmp_path) == ["spots.txt"]


def test_atomic_write_gives_the_mode_of_a_plain_open(tmp_path):
    """spots.txt is readable by others like any file the user writes (not mkstemp's 0600)."""
    umask = os.umask(0o022)
    try:
        path = write_atomic(tmp_path / "spots.txt", "spots: {}\n")
    finally:
        os.umask(umask)
    assert os.stat(path).st_mode & 0o777 == 0o644
