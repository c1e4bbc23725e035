"""The one parameter reader (param_reader): kinds, ranges, old names, unknown names, errors."""
import math
from dataclasses import dataclass, field

import pytest

from my_summit_path_planning.param_reader import (BOOL, CLAMPED, FLOAT, FLOAT_LIST, INT, INVALID, LIST, RENAMED,
                                                  STR, UNREAD, Field, Note, ParamError, Schema)


SCHEMA = Schema([
    Field("max_vel_x", FLOAT, 0.5, lo=0.0),                                     # [m/s]
    Field("vx_samples", INT, 3, lo=1, clamp=True),
    Field("holonomic_robot", BOOL, True),
    Field("world_model", STR, "costmap"),
    Field("y_vels", FLOAT_LIST, (-0.3, 0.3)),
    Field("plugins", LIST, factory=list),
    Field("sim_time", FLOAT, 1.0, lo=0.0, lo_open=True),                        # [s]
    Field("cost_factor", FLOAT, 3.0, lo=0.01, hi=5.0),
    Field("samples", INT, 10, lo=1, hi=20, clamp=True),
    Field("affected_maps", STR, "both", choices=("local", "global", "both"), fallback=True),
    Field("path_distance_bias", FLOAT, 0.6, old=("pdist_scale",)),
    Field("max_vel_trans", FLOAT, 0.55, renamed=("max_trans_vel",)),
    Field("escape_vel", FLOAT, -0.1, old=(("backup_vel", "backup_vel is deprecated: use escape_vel"),)),
    Field("clearing_radius", FLOAT, None, optional=True),
], accepted=("restore_defaults",))


def test_unset_names_take_the_declared_defaults():
    r = SCHEMA.read(None, "ns")
    assert r.values == {"max_vel_x": 0.5, "vx_samples": 3, "holonomic_robot": True, "world_model": "costmap",
                        "y_vels": (-0.3, 0.3), "plugins": [], "sim_time": 1.0, "cost_factor": 3.0, "samples": 10,
                        "affected_maps": "both", "path_distance_bias": 0.6, "max_vel_trans": 0.55,
                        "escape_vel": -0.1, "clearing_radius": None}
    assert r.notes == [] and r.given == frozenset()
    assert SCHEMA.read({}, "ns")["plugins"] is not r["plugins"]   # a fresh default each time


def test_values_are_typed_as_declared():
    r = SCHEMA.read({"max_vel_x": 1, "vx_samples": 5, "holonomic_robot": False, "y_vels": "[-0.2, 0.2]",
                     "plugins": [{"name": "a"}], "clearing_radius": None}, "ns")
    assert r["max_vel_x"] == 1.0 and isinstance(r["max_vel_x"], float)   # an int YAML value reads as float
    assert r["vx_samples"] == 5 and r["holonomic_robot"] is False
    assert r["y_vels"] == (-0.2, 0.2) and SCHEMA.read({"y_vels": [1, 2]}, "ns")["y_vels"] == (1.0, 2.0)
    assert r["clearing_radius"] is None and r.given == {"max_vel_x", "vx_samples", "holonomic_robot", "y_vels",
                                                        "plugins", "clearing_radius"}


@pytest.mark.parametrize("key, value, words", [
    ("max_vel_x", "fast", "must be float, got 'fast'"),
    ("max_vel_x", True, "must be float, got True"),           # a bool is not a number
    ("max_vel_x", math.nan, "must be finite, got nan"),
    ("vx_samples", 2.5, "must be int, got 2.5"),
    ("holonomic_robot", 1, "must be bool, got 1"),
    ("world_model", 3, "must be str, got 3"),
    ("y_vels", [0.1, "a"], "must be a list of floats"),
    ("y_vels", "[0.1, a]", "must be a list of floats"),
    ("plugins", "static_layer", "must be a list, got 'static_layer'"),
    ("max_vel_x", None, "must be float, got None"),           # None only where the field is optional
])
def test_a_bad_type_names_the_parameter(key, value, words):
    with pytest.raises(ParamError) as e:
        SCHEMA.read({key: value}, "move_base/Planner")
    assert f"move_base/Planner: '{key}' {words}" in str(e.value)
    assert f"(move_base/Planner/{key})" in str(e.value)       # the parameter's path, to find it


@pytest.mark.parametrize("key, value, words", [
    ("max_vel_x", -0.1, ">= 0.0"), ("sim_time", 0.0, "> 0.0"), ("cost_factor", 6.0, "in [0.01, 5.0]"),
    ("cost_factor", 0.0, "in [0.01, 5.0]")])
def test_a_value_out_of_a_rejecting_range_names_the_parameter_and_the_range(key, value, words):
    with pytest.raises(ParamError, match=rf"ns: '{key}' must be {words.replace('[', '.').replace(']', '.')}, "
                                         rf"got {value}"):
        SCHEMA.read({key: value}, "ns")
    assert SCHEMA.read({"sim_time": 1e-3, "cost_factor": 5.0}, "ns").notes == []   # the bounds that are in


def test_a_clamping_range_moves_the_value_to_the_bound_with_a_note():
    r = SCHEMA.read({"vx_samples": 0, "samples": 25}, "DWAPlannerROS")
    assert (r["vx_samples"], r["samples"]) == (1, 20) and isinstance(r["vx_samples"], int)
    assert [(n.kind, n.param) for n in r.notes] == [(CLAMPED, "vx_samples"), (CLAMPED, "samples")]
    assert r.notes[0] == "DWAPlannerROS: 'vx_samples' 0 raised to 1, its least value"
    assert r.notes[1] == "DWAPlannerROS: 'samples' 25 lowered to 20, its greatest value"
    custom = Schema([Field("vx_samples", INT, 3, lo=1, clamp=True, note="set {name} to {bound}")])
    assert custom.read({"vx_samples": -2}, "ns").notes == ["set vx_samples to 1"]


def test_a_value_outside_its_choices_falls_back_to_the_default_where_declared():
    r = SCHEMA.read({"affected_maps": "al"}, "clear")
    assert r["affected_maps"] == "both" and [n.kind for n in r.notes] == [INVALID]
    assert "'affected_maps' 'al' is not valid" in r.notes[0]
    strict = Schema([Field("mode", STR, "a", choices=("a", "b"))])
    with pytest.raises(ParamError, match="'mode' must be one of a, b, got 'c'"):
        strict.read({"mode": "c"}, "ns")


def test_an_old_name_is_read_when_the_current_one_is_unset_with_nav_cores_warning():
    r = SCHEMA.read({"pdist_scale": 0.9}, "TrajectoryPlannerROS")
    assert r["path_distance_bias"] == 0.9 and r.given == {"path_distance_bias"}
    assert r.notes == ["Parameter pdist_scale is deprecated. Please use the name path_distance_bias instead."]
    assert r.notes[0].kind == RENAMED and r.notes[0].param == "pdist_scale"
    both = SCHEMA.read({"pdist_scale": 0.9, "path_distance_bias": 0.7}, "ns")
    assert both["path_distance_bias"] == 0.7 and both.notes == []     # the current name wins, silently
    with pytest.raises(ParamError, match=r"ns: 'pdist_scale' must be float"):   # the name given is named
        SCHEMA.read({"pdist_scale": "far"}, "ns")


def test_an_old_name_with_its_own_warning_is_warned_about_whenever_set():
    for params in ({"backup_vel": -0.2}, {"backup_vel": -0.2, "escape_vel": -0.3}):
        r = SCHEMA.read(params, "ns")
        assert r["escape_vel"] == params.get("escape_vel", -0.2)
        assert r.notes == ["backup_vel is deprecated: use escape_vel"]


def test_a_renamed_name_is_warned_about_and_not_read():
    r = SCHEMA.read({"max_trans_vel": 2.0}, "DWAPlannerROS")
    assert r["max_vel_trans"] == 0.55 and r.given == frozenset()
    assert r.notes == ["Parameter max_trans_vel is deprecated (and will not load properly). Use max_vel_trans "
                       "instead."]


def test_unknown_names_are_noted_once_each_with_the_nearest_known_name():
    r = SCHEMA.read({"max_vel_xx": 1.0, "restore_defaults": True, "pdist_scale": 0.5, 7: 1}, "~Planner")
    unread = [n for n in r.notes if n.kind == UNREAD]
    assert [n.param for n in unread] == ["7", "max_vel_xx"]   # accepted and old names are known
    assert unread[1] == "~Planner: 'max_vel_xx' is not a parameter this node reads; ignored " \
                        "(did you mean 'max_vel_x'?)"
    assert SCHEMA.read({"foo": 1}, "ns", note_where="").notes[0].startswith("'foo' is not a parameter")


def test_a_namespace_that_is_not_a_mapping_and_the_callers_error_class():
    with pytest.raises(ParamError, match="ns: expected a mapping of parameters"):
        SCHEMA.read([("max_vel_x", 1.0)], "ns")

    class LayerError(ValueError):
        pass
    with pytest.raises(LayerError, match="'max_vel_x' must be float"):
        SCHEMA.read({"max_vel_x": "x"}, "layer", error=LayerError)


def test_notes_are_strings_with_kind_and_param():
    n = Note(UNREAD, "foo", "text")
    assert n == "text" and isinstance(n, str) and (n.kind, n.param) == (UNREAD, "foo")


def test_a_dataclass_declares_its_fields_with_overrides():
    @dataclass
    class Config:
        max_vel_x: float = 0.5            # [m/s]
        vx_samples: int = 3
        use: bool = True
        frame: str = "map"
        plugins: list = field(default_factory=list)
        radius: float = None
        notes: list = field(default_factory=list)   # not a parameter

    schema = Schema.of(Config, internal=("notes",), vx_samples=dict(lo=1, clamp=True), max_vel_x=dict(lo=0.0))
    assert sorted(schema.fields) == ["frame", "max_vel_x", "plugins", "radius", "use", "vx_samples"]
    r = schema.read({"vx_samples": 0, "radius": None, "notes": 1}, "ns")
    cfg = Config(**r.values)
    assert cfg.vx_samples == 1 and cfg.radius is None and cfg.plugins == [] and cfg.notes == []
    assert [n.kind for n in r.notes] == [CLAMPED, UNREAD]
    with pytest.raises(ParamError, match="'max_vel_x' must be >= 0.0"):
        schema.read({"max_vel_x": -1}, "ns")
    with pytest.raises(ParamError, match="'use' must be bool"):
        schema.read({"use": "yes"}, "ns")
    with pytest.raises(ValueError, match="no field"):
        Schema.of(Config, max_vel_y=dict(lo=0.0))
