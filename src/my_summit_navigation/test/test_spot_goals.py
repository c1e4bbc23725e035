"""Unit tests of my_summit_navigation.spot_goals: spot lookup, file faults, answer texts,
command-line targets (no ROS master)."""
import math
import os
import threading

import pytest
from numpy.testing import assert_allclose

from my_summit_localization.spots import Spot, SpotsError, spots_to_yaml
from my_summit_navigation import spot_goals as sg

PKG = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
COMMITTED = os.path.join(os.path.dirname(PKG), "my_summit_localization", "config", "spots.yaml")
COURSE = {"room": (14.0, -3.5, 0.0), "turtle": (15.6, -5.7, -math.pi / 2), "table": (13.8, -1.8, math.pi)}


def write_spots(path, spots, frame_id="map"):
    path.write_text(spots_to_yaml({k: Spot.from_xy_yaw(*v) for k, v in spots.items()}, frame_id))
    return path


def test_committed_spots_file_has_the_course_spots():
    book = sg.SpotBook(COMMITTED)
    assert book.refresh()
    assert book.error is None
    assert book.labels() == ["room", "turtle", "table"]
    for label, (x, y, yaw) in COURSE.items():
        spot, frame, refusal = book.lookup(label)
        assert refusal is None and frame == "map"
        assert_allclose([spot.x, spot.y], [x, y], atol=1e-9)
        assert abs(math.remainder(spot.yaw - yaw, 2 * math.pi)) < 1e-9


def test_recorder_spots_txt_reads_the_same(tmp_path):
    """spots.txt as spot_recorder writes it (header comment, its own frame)."""
    from my_summit_localization.spots import SpotRecorder
    rec = SpotRecorder(str(tmp_path / "spots.txt"), frame_id="map")
    for label, pose in COURSE.items():
        assert rec.handle(label, Spot.from_xy_yaw(*pose))[0]
    assert rec.handle("end", None)[0]
    book = sg.SpotBook(tmp_path / "spots.txt")
    book.refresh()
    assert book.error is None and book.labels() == list(COURSE)
    spot, frame, _ = book.lookup("  turtle ")      # white space around a label is ignored
    assert frame == "map"
    assert_allclose([spot.x, spot.y, spot.yaw], [15.6, -5.7, -math.pi / 2], atol=1e-9)


def test_unknown_and_empty_labels_are_refused_listing_the_known_ones(tmp_path):
    book = sg.SpotBook(write_spots(tmp_path / "s.yaml", COURSE))
    book.refresh()
    spot, frame, refusal = book.lookup("kitchen")
    assert spot is None and frame is None
    assert refusal == "unknown label 'kitchen'; known labels: room, turtle, table"
    for empty in ("", "   ", None):
        spot, _, refusal = book.lookup(empty)
        assert spot is None
        assert refusal.startswith("the label is empty") and "room, turtle, table" in refusal
    assert book.lookup("Room")[2].startswith("unknown label 'Room'")   # labels are case-sensitive


def test_missing_file_refuses_every_call_naming_the_file(tmp_path):
    path = tmp_path / "nowhere" / "spots.txt"
    book = sg.SpotBook(path)
    book.refresh()
    assert book.error is not None and str(path) in book.error
    for label in ("room", "", "kitchen"):
        spot, _, refusal = book.lookup(label)
        assert spot is None
        assert refusal.startswith("no spots to go to: ") and str(path) in refusal
        assert "cannot read the spots file" in refusal


@pytest.mark.parametrize("text, fault", [
    ("spots: [room, table\n", "malformed YAML"),
    ("- just a list\n", "expected a mapping with a 'spots' key"),
    ("spots:\n  room: {position: {x: 1.0, y: 2.0}}\n", "expected {position"),
    ("spots:\n  room: {position: {x: 1.0, y: .nan}, orientation: {x: 0, y: 0, z: 0, w: 1}}\n", "finite"),
    ("spots:\n  room: {position: {x: 1.0, y: 2.0}, orientation: {x: 0, y: 0, z: 0, w: 2}}\n", "unit quaternion"),
])
def test_malformed_file_refuses_every_call_naming_file_and_fault(tmp_path, text, fault):
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    book = sg.SpotBook(path)
    book.refresh()
    spot, _, refusal = book.lookup("room")
    assert spot is None
    assert str(path) in refusal and fault in refusal, refusal


def test_committed_malformed_fixture_is_refused():
    path = os.path.join(PKG, "test", "data", "malformed_spots.yaml")
    book = sg.SpotBook(path)
    book.refresh()
    assert book.error is not None and "malformed YAML" in book.error and path in book.error


def test_file_reread_when_it_changes_or_appears(tmp_path):
    path = tmp_path / "spots.txt"
    book = sg.SpotBook(path)
    assert book.refresh()
    assert book.error is not None
    assert not book.refresh()                 # still missing: nothing new
    write_spots(path, {"room": COURSE["room"]})
    assert book.refresh()
    assert book.labels() == ["room"] and book.error is None
    assert not book.refresh()                 # unchanged: not read again
    os.replace(write_spots(tmp_path / "new.txt", COURSE), path)   # the recorder's atomic rename
    assert book.refresh()
    assert book.labels() == ["room", "turtle", "table"]
    path.write_text("spots: {")
    assert book.refresh()
    assert book.lookup("room")[0] is None and "malformed YAML" in book.lookup("room")[2]


def test_loader_is_a_collaborator():
    calls = []

    def loader(path):
        calls.append(path)
        if len(calls) == 1:
            raise SpotsError(f"{path}: broken")
        return "world", {"a": Spot(1.0, 2.0)}

    book = sg.SpotBook("/no/such/file", loader=loader)
    book.refresh()
    assert book.lookup("a")[2] == "no spots to go to: /no/such/file: broken"
    book._read = False                       # force a re-read
    book.refresh()
    spot, frame, refusal = book.lookup("a")
    assert (spot.x, spot.y, frame, refusal) == (1.0, 2.0, "world", None)


def test_lookup_is_thread_safe_during_rereads(tmp_path):
    path = write_spots(tmp_path / "s.yaml", COURSE)
    book = sg.SpotBook(path)
    book.refresh()
    errors = []

    def reader():
        for _ in range(300):
            spot, _, refusal = book.lookup("room")
            if refusal is not None and not refusal.startswith("no spots"):
                errors.append(refusal)

    threads = [threading.Thread(target=reader) for _ in range(4)]
    for t in threads:
        t.start()
    for _ in range(30):
        book._read = False
        book.refresh()
    for t in threads:
        t.join()
    assert errors == []


def test_goal_status_constants_match_actionlib_msgs():
    from actionlib_msgs.msg import GoalStatus
    for value, name in sg.STATE_NAMES.items():
        assert getattr(GoalStatus, name) == value


def test_answers_for_move_base_outcomes():
    assert sg.answer_for_state(sg.SUCCEEDED, "Goal reached.") == (True, "OK")
    reason = "Failed to find a valid plan. Even after executing recovery behaviors."
    ok, text = sg.answer_for_state(sg.ABORTED, reason)
    assert not ok and text == ("move_base aborted the goal: Failed to find a valid plan. "
                               "Even after executing recovery behaviors.")
    ok, text = sg.answer_for_state(sg.ABORTED, "")
    assert not ok and text.endswith("(no reason given)")
    for state in (sg.PREEMPTED, sg.RECALLED):
        ok, text = sg.answer_for_state(state, "canceled")
        assert not ok and text.startswith("move_base preempted the goal") and text.endswith("canceled")
    assert sg.answer_for_state(sg.REJECTED, "bad")[1] == "move_base rejected the goal: bad"
    assert not sg.answer_for_state(sg.LOST, "")[0]
    assert sg.answer_for_state(sg.ACTIVE, "x") == (False, "move_base ended the goal in state ACTIVE: x")


def test_other_answer_texts():
    assert sg.answer_preempted("room") == "preempted by a newer call (label 'room')"
    assert sg.answer_preempted("room").startswith(sg.PREEMPTED_BY_NEWER)
    text = sg.answer_no_server("/no_such_move_base", 2.0)
    assert text.startswith("move_base not available") and "'/no_such_move_base' within 2.0 s" in text
    assert "within 30.0 s" in sg.answer_goal_timeout("room", 30.0)
    assert "shutting down" in sg.answer_shutdown()
    assert sg.describe("table", Spot.from_xy_yaw(13.8, -1.8, math.pi), "map") == \
        "'table' at x 13.80 m, y -1.80 m, yaw 180 deg in frame map"


def test_parse_target():
    assert sg.parse_target(["room"]) == ("label", "room")
    kind, spot = sg.parse_target(["14.0", "-3.5", "1.5707963"])
    assert kind == "pose"
    assert_allclose([spot.x, spot.y, spot.yaw], [14.0, -3.5, 1.5707963], atol=1e-9)
    for bad, why in [([], "expected a label or x y yaw, got 0"), (["a", "b"], "got 2"),
                     (["1", "2", "north"], "must be numbers"), (["1", "nan", "0"], "finite"),
                     (["  "], "empty"), (["1", "2", "3", "4"], "got 4")]:
        with pytest.raises(sg.UsageError, match=why):
            sg.parse_target(bad)
