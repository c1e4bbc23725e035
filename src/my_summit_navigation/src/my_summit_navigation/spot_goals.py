"""Spot lookup and the answers of /get_coordinates: the logic behind the course's step 4.

The course's get_coordinates node takes a label, looks up the pose saved under it (the
spots file of my_summit_localization: its committed ``config/spots.yaml`` or the
``spots.txt`` the spot recorder writes, same schema, read by
``my_summit_localization.spots.load_spots``), sends that pose to move_base and answers
``navigation_successfull`` + ``message``. This module holds everything of that which
needs no ROS:

- ``SpotBook``: the spots of one file, re-read whenever the file changes (so spots saved
  with /save_spot + ``end`` while the server runs are found without a restart); a file
  that is missing or malformed is kept as the reason every call is refused.
- ``SpotBook.lookup``: label -> (spot, frame) or the refusal text (bad file, empty label,
  unknown label listing the known ones).
- the answer texts: ``OK``, ``answer_for_state`` (move_base's terminal goal state and
  result text -> answer), ``answer_no_server``, ``answer_preempted``,
  ``answer_goal_timeout``, ``answer_shutdown``.
- ``parse_target``: the command-line target of send_coordinates_action_client.py (a
  label, or x y yaw).

No rospy here: scripts/get_coordinates_service_server.py and
scripts/send_coordinates_action_client.py are the adapters.
"""
import math
import os
import threading

from my_summit_localization.spots import Spot, SpotsError, load_spots

OK = "OK"                                        # the answer when the robot got there
PREEMPTED_BY_NEWER = "preempted by a newer call"  # start of the older call's answer

# actionlib_msgs/GoalStatus values (copied so this module needs no ROS message import;
# test_spot_goals checks them against actionlib_msgs)
PENDING, ACTIVE, PREEMPTED, SUCCEEDED, ABORTED, REJECTED, PREEMPTING, RECALLING, RECALLED, LOST = range(10)
STATE_NAMES = {PENDING: "PENDING", ACTIVE: "ACTIVE", PREEMPTED: "PREEMPTED", SUCCEEDED: "SUCCEEDED",
               ABORTED: "ABORTED", REJECTED: "REJECTED", PREEMPTING: "PREEMPTING",
               RECALLING: "RECALLING", RECALLED: "RECALLED", LOST: "LOST"}


class SpotBook:
    """The labelled spots of one spots file, re-read when the file changes.

    path: the spots file (YAML schema of my_summit_localization.spots);
    loader: path -> (frame_id, {label: Spot}), raising SpotsError naming the file and
    the fault (default load_spots; tests hand in their own).
    Thread-safe: the service answers each call in its own thread.
    """

    def __init__(self, path, loader=load_spots):
        self.path = str(path)
        self._loader = loader
        self._lock = threading.Lock()
        self._stamp = None        # (mtime [ns], size [B], inode) of the file last read
        self._read = False        # read at least once
        self.frame_id = None      # frame of every spot, None while the file is unusable
        self.spots = {}           # label -> Spot, in the file's order
        self.error = None         # why the file is unusable (SpotsError text), or None

    def refresh(self):
        """Read the file if it changed since the last read (or was never read).

        Returns True when it was (re)read. A missing file is read again once it appears.
        """
        try:
            st = os.stat(self.path)
            stamp = (st.st_mtime_ns, st.st_size, st.st_ino)
        except OSError:
            stamp = None
        with self._lock:
            if self._read and stamp == self._stamp:
                return False
            self._read, self._stamp = True, stamp
            try:
                self.frame_id, spots = self._loader(self.path)
                self.spots, self.error = dict(spots), None
            except SpotsError as e:
                self.frame_id, self.spots, self.error = None, {}, str(e)
            return True

    def labels(self):
        """The known labels, in the file's order."""
        with self._lock:
            return list(self.spots)

    def lookup(self, label):
        """(Spot, frame_id, None) for a known label, else (None, None, refusal text).

        The label is stripped of surrounding white space. Refusals, in this order: the
        spots file is unusable (every call gets that reason), the label is empty, the
        label is unknown (the text lists the known labels).
        """
        with self._lock:
            if self.error is not None:
                return None, None, f"no spots to go to: {self.error}"
            known = ", ".join(self.spots) or "(none)"
            label = (label or "").strip()
            if not label:
                return None, None, f"the label is empty; give one of the known labels: {known}"
            spot = self.spots.get(label)
            if spot is None:
                return None, None, f"unknown label '{label}'; known labels: {known}"
            return spot, self.frame_id, None


# -- answers ------------------------------------------------------------------------------
def describe(label, spot, frame_id):
    """'label' at x, y [m], yaw [deg] in frame: for logs and the command line."""
    return (f"'{label}' at x {spot.x:.2f} m, y {spot.y:.2f} m, yaw {math.degrees(spot.yaw):.0f} deg "
            f"in frame {frame_id}")


def answer_for_state(state, text):
    """(navigation_successfull, message) for move_base's terminal goal state and its text.

    state: actionlib_msgs/GoalStatus value; text: the goal's status text (move_base says
    there why it aborted). SUCCEEDED is the only success.
    """
    text = (text or "").strip() or "(no reason given)"
    if state == SUCCEEDED:
        return True, OK
    if state == ABORTED:
        return False, f"move_base aborted the goal: {text}"
    if state in (PREEMPTED, RECALLED):
        return False, f"move_base preempted the goal (canceled, or replaced by another client's goal): {text}"
    if state == REJECTED:
        return False, f"move_base rejected the goal: {text}"
    if state == LOST:
        return False, "move_base lost the goal (the action server went away)"
    return False, f"move_base ended the goal in state {STATE_NAMES.get(state, state)}: {text}"


def answer_no_server(action_name, timeout):
    """Refusal when no move_base action server answers within timeout [s]."""
    return (f"move_base not available: no action server '{action_name}' within {timeout:.1f} s "
            "(is move_base running?)")


def answer_preempted(newer_label):
    """The older call's answer when a newer /get_coordinates call took over move_base."""
    return f"{PREEMPTED_BY_NEWER} (label '{newer_label}')"


def answer_goal_timeout(label, timeout):
    """Answer when move_base did not finish within goal_timeout [s]; the goal is canceled."""
    return f"'{label}' not reached within {timeout:.1f} s (goal_timeout); the goal was canceled"


def answer_shutdown():
    """Answer of a call still waiting when the node shuts down."""
    return "the node is shutting down; the goal was canceled"


# -- the command line -----------------------------------------------------------------------
class UsageError(ValueError):
    """A command-line target that is neither a label nor x y yaw; the text says why."""


def parse_target(args):
    """('label', label) or ('pose', Spot) of the command-line arguments.

    args: [LABEL] or [X, Y, YAW] with X, Y [m] and YAW [rad] finite numbers.
    UsageError otherwise.
    """
    args = list(args)
    if len(args) == 1:
        label = args[0].strip()
        if not label:
            raise UsageError("the label is empty")
        return "label", label
    if len(args) == 3:
        try:
            x, y, yaw = (float(a) for a in args)
        except ValueError:
            raise UsageError(f"x y yaw must be numbers, got {' '.join(args)}") from None
        if not all(math.isfinite(v) for v in (x, y, yaw)):
            raise UsageError(f"x y yaw must be finite, got {' '.join(args)}")
        return "pose", Spot.from_xy_yaw(x, y, yaw)
    raise UsageError(f"expected a label or x y yaw, got {len(args)} arguments")
