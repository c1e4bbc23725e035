"""Labelled spots: the store behind /save_spot, the spots YAML schema, atomic writing.

The course's spot_recorder stores the robot's amcl pose under a label on each
``/save_spot`` call and writes every spot to ``spots.txt`` on the label ``end``. Here the
file is YAML in the same schema as the committed ``config/spots.yaml``, so the navigation
step can read either:

    frame_id: map            # frame of every pose (the map amcl localizes in)
    spots:
      room:                  # label
        position: {x: 14.0, y: -3.5, z: 0.0}             # [m]
        orientation: {x: 0.0, y: 0.0, z: 0.0, w: 1.0}    # unit quaternion (yaw about z)

(the fields of a geometry_msgs/Pose). ``frame_id`` is optional (default ``map``);
labels are non-empty strings, ``end`` is reserved (it is the write command).

The file is written atomically (a temporary file in the same directory, flushed and
fsync'ed, then renamed over the target), so a failed write leaves an earlier file intact.
No rospy here: the node (nodes/spot_recorder) is the adapter.
"""
import math
import os
from collections import OrderedDict
from dataclasses import dataclass

import yaml

from summit_nav_common import files
from summit_nav_common.geometry import yaw_of_quaternion, yaw_to_quaternion_zw

END_LABEL = "end"          # the label that writes the file instead of storing a spot
DEFAULT_FRAME = "map"      # frame of the poses when a file does not name one
UNIT_TOLERANCE = 1e-3      # |q| may differ from 1 by this much in a loaded file [-]


class SpotsError(ValueError):
    """A spots file or spot that cannot be read, stored or written; the message says why."""


@dataclass(frozen=True)
class Spot:
    """A pose: position (x, y, z) [m] and orientation quaternion (x, y, z, w)."""

    x: float
    y: float
    z: float = 0.0
    qx: float = 0.0
    qy: float = 0.0
    qz: float = 0.0
    qw: float = 1.0

    @classmethod
    def from_xy_yaw(cls, x, y, yaw):
        """Spot at (x [m], y [m]) facing yaw [rad] about z."""
        return cls(float(x), float(y), 0.0, 0.0, 0.0, *yaw_to_quaternion_zw(yaw))

    @property
    def yaw(self):
        """Yaw [rad] of the orientation (roll and pitch ignored)."""
        return yaw_of_quaternion(self.qx, self.qy, self.qz, self.qw)

    def as_dict(self):
        """The schema's mapping {position: {x, y, z}, orientation: {x, y, z, w}}."""
        return {"position": {"x": self.x, "y": self.y, "z": self.z},
                "orientation": {"x": self.qx, "y": self.qy, "z": self.qz, "w": self.qw}}

    def check(self, label="spot"):
        """SpotsError unless every value is finite and the quaternion is non-zero."""
        values = (self.x, self.y, self.z, self.qx, self.qy, self.qz, self.qw)
        if not all(isinstance(v, (int, float)) and math.isfinite(v) for v in values):
            raise SpotsError(f"spot '{label}': pose values must be finite numbers, got {values}")
        if math.sqrt(self.qx ** 2 + self.qy ** 2 + self.qz ** 2 + self.qw ** 2) < 0.5:
            raise SpotsError(f"spot '{label}': orientation is not a unit quaternion")
        return self


# -- the schema -------------------------------------------------------------------------
def spots_to_yaml(spots, frame_id=DEFAULT_FRAME, header=None):
    """YAML text of {label: Spot} in the schema above, labels in the given order.

    header: optional comment text (one or more lines) put at the top.
    """
    doc = {"frame_id": frame_id,
           "spots": {label: spot.as_dict() for label, spot in spots.items()}}
    text = yaml.safe_dump(doc, default_flow_style=None, sort_keys=False)
    if header:
        text = "".join(f"# {line}\n" for line in header.splitlines()) + text
    return text


def parse_spots(text, source="spots"):
    """(frame_id, OrderedDict label -> Spot) of YAML text in the schema; SpotsError naming
    `source` and what is wrong otherwise."""
    try:
        doc = yaml.safe_load(text)
    except yaml.YAMLError as e:
        raise SpotsError(f"{source}: malformed YAML: {e}") from e
    if not isinstance(doc, dict) or "spots" not in doc:
        raise SpotsError(f"{source}: expected a mapping with a 'spots' key")
    frame_id = doc.get("frame_id", DEFAULT_FRAME)
    if not isinstance(frame_id, str) or not frame_id:
        raise SpotsError(f"{source}: frame_id must be a non-empty string, got {frame_id!r}")
    raw = doc["spots"]
    if not isinstance(raw, dict) or not raw:
        raise SpotsError(f"{source}: 'spots' must be a non-empty mapping of label -> pose")
    spots = OrderedDict()
    for label, entry in raw.items():
        spots[str(label)] = _parse_spot(label, entry, source)
    return frame_id, spots


def _parse_spot(label, entry, source):
    where = f"{source}: spot '{label}'"
    if not isinstance(entry, dict) or "position" not in entry or "orientation" not in entry:
        raise SpotsError(f"{where}: expected {{position: {{x, y, z}}, orientation: {{x, y, z, w}}}}")
    pos, ori = entry["position"], entry["orientation"]
    if not isinstance(pos, dict) or not isinstance(ori, dict):
        raise SpotsError(f"{where}: position and orientation must be mappings")
    try:
        values = [_number(pos, k, 0.0 if k == "z" else None) for k in ("x", "y", "z")]
        values += [_number(ori, k, None) for k in ("x", "y", "z", "w")]
    except KeyError as e:
        raise SpotsError(f"{where}: missing {e.args[0]}") from None
    except TypeError as e:
        raise SpotsError(f"{where}: {e}") from None
    spot = Spot(*values).check(f"{source}: {label}")
    norm = math.sqrt(spot.qx ** 2 + spot.qy ** 2 + spot.qz ** 2 + spot.qw ** 2)
    if abs(norm - 1.0) > UNIT_TOLERANCE:
        raise SpotsError(f"{where}: orientation is not a unit quaternion (norm {norm:.4f})")
    return spot


def _number(mapping, key, default):
    if key not in mapping:
        if default is None:
            raise KeyError(key)
        return default
    v = mapping[key]
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise TypeError(f"{key} must be a finite number, got {v!r}")
    return float(v)


def load_spots(path):
    """(frame_id, OrderedDict label -> Spot) of a spots file; SpotsError naming the file."""
    try:
        with open(path) as f:
            text = f.read()
    except OSError as e:
        raise SpotsError(f"{path}: cannot read the spots file: {e.strerror or e}") from e
    return parse_spots(text, source=str(path))


# -- atomic write -----------------------------------------------------------------------
def write_atomic(path, text):
    """Write text to path atomically (summit_nav_common.files.write_atomic); on failure an
    existing file at path is left as it was and SpotsError says which path and why.
    Returns the absolute path written."""
    path = os.path.abspath(os.path.expanduser(str(path)))
    if os.path.isdir(path):
        raise SpotsError(f"cannot write {path}: it is a directory")
    try:
        files.write_atomic(path, text)
    except OSError as e:
        raise SpotsError(f"cannot write {path}: {e.strerror or e}") from e
    return path


# -- the recorder -----------------------------------------------------------------------
class SpotRecorder:
    """The logic of /save_spot: store labelled poses, write them all on ``end``.

    path: the spots file written on ``end``; frame_id: frame of the stored poses.
    ``handle(label, pose)`` answers a call with (saved: bool, message: str); pose is the
    current Spot, or None when the localization has no pose yet.
    """

    def __init__(self, path, frame_id=DEFAULT_FRAME):
        self.path = path
        self.frame_id = frame_id
        self.spots = OrderedDict()

    def handle(self, label, pose):
        """One /save_spot call; returns (ok, message). Nothing is stored on a refusal."""
        if not isinstance(label, str) or not label.strip():
            return False, "refused: the label is empty; give a name such as 'room' (or 'end' to write the file)"
        label = label.strip()
        if label == END_LABEL:
            return self.write()
        if pose is None:
            return False, (f"refused: no pose yet for '{label}' (amcl has not published amcl_pose; "
                           "is amcl running and localized?)")
        try:
            pose.check(label)
        except SpotsError as e:
            return False, f"refused: {e}"
        replaced = label in self.spots
        self.spots[label] = pose
        where = f"x {pose.x:.3f} m, y {pose.y:.3f} m, yaw {math.degrees(pose.yaw):.1f} deg"
        if replaced:
            return True, f"replaced the earlier pose of '{label}' with {where} ({len(self.spots)} spots)"
        return True, f"saved '{label}' at {where} ({len(self.spots)} spots)"

    def write(self):
        """Write every stored spot to self.path; (ok, message)."""
        if not self.spots:
            return False, "refused: no spot stored yet, nothing written (save some labels before 'end')"
        text = spots_to_yaml(self.spots, self.frame_id,
                             header="Spots recorded by my_summit_localization's spot_recorder (/save_spot).")
        try:
            path = write_atomic(self.path, text)
        except SpotsError as e:
            return False, f"not saved: {e}"
        return True, f"wrote {len(self.spots)} spots ({', '.join(self.spots)}) to {path}"
