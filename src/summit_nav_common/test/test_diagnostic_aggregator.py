"""summit_nav_common.diagnostic_aggregator against diagnostic_aggregator's documented
behaviour (ROS wiki; GenericAnalyzer, AnalyzerGroup, Aggregator in ros/diagnostics noetic)."""
import pytest

from summit_nav_common.diagnostic_aggregator import (ERROR, OK, STALE, WARN, Aggregator, ConfigError, Status,
                                                     remove_leading_name_chaff)

GENERIC = "diagnostic_aggregator/GenericAnalyzer"
GROUP = "diagnostic_aggregator/AnalyzerGroup"

NAV = {"analyzers": {"navigation": {"type": GROUP, "path": "Navigation Stack", "analyzers": {
    "localization": {"type": GENERIC, "path": "Localization", "startswith": ["amcl", "ekf"]},
    "planning": {"type": GENERIC, "path": "Planning", "startswith": "move_base"},
    "simulator": {"type": GENERIC, "path": "Simulator", "startswith": "summit_xl_sim"}}}}}


def by_name(statuses):
    return {s.name: s for s in statuses}


def agg_with(params, statuses, t_add=0.0, t_report=0.5):
    agg = Aggregator(params, 0.0)
    agg.add(statuses, t_add)
    return agg, agg.report(t_report)


def test_items_are_renamed_under_their_paths_and_groups_report_their_worst_child():
    _, (out, top) = agg_with(NAV, [Status("amcl: Standard deviation", WARN, "Too large"),
                                   Status("move_base: Controller", OK, "20.0 Hz"),
                                   Status("summit_xl_sim: Battery", OK, "80 %")])
    s = by_name(out)
    assert s["/Navigation Stack/Localization/amcl: Standard deviation"].level == WARN
    assert s["/Navigation Stack/Localization"].level == WARN
    assert s["/Navigation Stack/Localization"].message == "Warning"
    assert s["/Navigation Stack/Localization"].values == [("amcl: Standard deviation", "Too large")]
    assert s["/Navigation Stack/Planning"].message == "OK"
    nav = s["/Navigation Stack"]
    assert (nav.level, nav.message) == (WARN, "Warning")
    assert nav.values == [("Localization", "Warning"), ("Planning", "OK"), ("Simulator", "OK")]
    # a group's header comes after its children's statuses; analyzers in name order
    names = [x.name for x in out]
    assert names[-1] == "/Navigation Stack"
    assert names.index("/Navigation Stack/Localization") < names.index("/Navigation Stack/Planning")
    assert top.name == "toplevel_state" and top.level == WARN


def test_error_child_makes_the_top_level_error():
    _, (out, top) = agg_with(NAV, [Status("move_base: Global planner", ERROR, "no plan"),
                                   Status("amcl: Scan rate", OK, "40 Hz")])
    assert by_name(out)["/Navigation Stack"].message == "Error"
    assert top.level == ERROR


def test_match_kinds():
    params = {"analyzers": {
        "a": {"type": GENERIC, "path": "A", "contains": "rate"},
        "b": {"type": GENERIC, "path": "B", "name": "exact one"},
        "c": {"type": GENERIC, "path": "C", "regex": "mo.*_base: .*"},
        "d": {"type": GENERIC, "path": "D", "startswith": "amcl"}}}
    _, (out, _) = agg_with(params, [Status("amcl: Scan rate", OK), Status("exact one", OK),
                                    Status("exact one two", OK), Status("move_base: X", OK)])
    s = by_name(out)
    assert "/A/amcl: Scan rate" in s and "/D/amcl: Scan rate" in s   # an item goes to every match
    assert "/B/exact one" in s and "/B/exact one two" not in s
    assert "/C/move_base: X" in s
    assert "/Other/exact one two" in s   # matched by nothing
    assert "/C/amcl: Scan rate" not in s  # regex matches the whole name only


def test_slashes_in_item_names_become_spaces():
    _, (out, _) = agg_with(NAV, [Status("amcl/sub: Check", OK)])
    assert "/Navigation Stack/Localization/amcl sub: Check" in by_name(out)


@pytest.mark.parametrize("name, chaff, expected", [
    ("/PREFIX/hokuyo_node: Connection Status", "hokuyo_node", "/PREFIX/Connection Status"),
    ("/PREFIX/hokuyo_node Connection", "hokuyo_node", "/PREFIX/Connection"),
    ("/PREFIX/other: x", "hokuyo_node", "/PREFIX/other: x"),
    ("/hokuyo_node/hokuyo_node: x", "hokuyo_node", "/hokuyo_node/hokuyo_node: x"),  # first occurrence rule
    ("/P/x", "", "/P/x"),
])
def test_remove_leading_name_chaff(name, chaff, expected):
    assert remove_leading_name_chaff(name, chaff) == expected


def test_find_and_remove_prefix_matches_and_strips():
    params = {"analyzers": {"loc": {"type": GENERIC, "path": "Localization", "find_and_remove_prefix": "amcl"}}}
    _, (out, _) = agg_with(params, [Status("amcl: Standard deviation", OK, "OK")])
    assert "/Localization/Standard deviation" in by_name(out)


def test_remove_prefix_without_matching():
    params = {"analyzers": {"loc": {"type": GENERIC, "path": "L", "contains": "Scan", "remove_prefix": "amcl"}}}
    _, (out, _) = agg_with(params, [Status("amcl: Scan rate", OK)])
    assert "/L/Scan rate" in by_name(out)


def test_stale_after_timeout_some_stale_is_error_all_stale_is_stale():
    agg = Aggregator(NAV, 0.0)
    agg.add([Status("amcl: Standard deviation", OK, "OK")], 0.0)
    agg.add([Status("amcl: Scan rate", OK, "40 Hz")], 4.0)
    out, top = agg.report(6.0)         # the first is 6 s old (> timeout 5 s), the second 2 s
    s = by_name(out)
    assert s["/Navigation Stack/Localization/amcl: Standard deviation"].level == STALE
    assert s["/Navigation Stack/Localization/amcl: Standard deviation"].message == "OK"
    assert (s["/Navigation Stack/Localization"].level, s["/Navigation Stack/Localization"].message) == \
        (ERROR, "Error")
    assert top.level == ERROR
    out, top = agg.report(10.0)        # both stale now
    s = by_name(out)
    assert (s["/Navigation Stack/Localization"].level, s["/Navigation Stack/Localization"].message) == \
        (STALE, "Stale")
    # the group: one child Stale, the others empty (an empty analyzer is Stale too)
    assert s["/Navigation Stack"].level == STALE and top.level == STALE


def test_an_analyzer_with_nothing_yet_is_stale_and_makes_its_group_error():
    _, (out, top) = agg_with(NAV, [Status("amcl: Scan rate", OK, "40 Hz")])
    s = by_name(out)
    assert s["/Navigation Stack/Planning"].level == STALE and s["/Navigation Stack/Planning"].values == []
    assert s["/Navigation Stack"].level == ERROR
    assert top.level == ERROR


def test_timeout_zero_never_stale_and_discard_stale_drops_items():
    params = {"analyzers": {
        "keep": {"type": GENERIC, "path": "Keep", "startswith": "a", "timeout": 0},
        "drop": {"type": GENERIC, "path": "Drop", "startswith": "b", "timeout": 1.0, "discard_stale": True}}}
    agg = Aggregator(params, 0.0)
    agg.add([Status("a: x", OK), Status("b: y", WARN)], 0.0)
    s = by_name(agg.report(100.0)[0])
    assert s["/Keep/a: x"].level == OK
    assert "/Drop/b: y" not in s and s["/Drop"].level == STALE


def test_expected_items_missing_are_reported():
    params = {"analyzers": {"p": {"type": GENERIC, "path": "Planning",
                                  "expected": ["move_base: Controller", "move_base: Recovery"]}}}
    _, (out, _) = agg_with(params, [Status("move_base: Controller", OK, "20 Hz")])
    s = by_name(out)
    assert s["/Planning/move_base: Recovery"].level == STALE
    assert s["/Planning/move_base: Recovery"].message == "Missing"
    assert s["/Planning"].level == ERROR   # one stale among fresh ones


def test_num_items():
    params = {"analyzers": {"p": {"type": GENERIC, "path": "P", "startswith": "m", "num_items": 2}}}
    _, (out, _) = agg_with(params, [Status("m: a", OK)])
    assert (by_name(out)["/P"].level, by_name(out)["/P"].message) == (ERROR, "Expected 2, found 1")


def test_other_collects_unmatched_then_drops_them_when_stale():
    agg = Aggregator(NAV, 0.0)
    agg.add([Status("rosout: x", WARN, "w")], 0.0)
    s = by_name(agg.report(1.0)[0])
    assert s["/Other/rosout: x"].level == WARN and s["/Other"].message == "Warning"
    s = by_name(agg.report(7.0)[0])
    assert "/Other/rosout: x" not in s and "/Other" not in s


def test_other_as_errors_and_base_path():
    params = dict(NAV, base_path="Robot", other_as_errors=True)
    _, (out, top) = agg_with(params, [Status("rosout: x", OK), Status("amcl: a", OK)])
    s = by_name(out)
    assert s["/Robot/Other"].level == ERROR and s["/Robot/Other"].message == 'Unanalyzed items found in "Other"'
    assert "/Robot/Navigation Stack/Localization/amcl: a" in s
    assert "/Robot" in s   # the top group has a header when there is a base path
    assert top.level == ERROR


def test_no_analyzers_everything_is_other():
    _, (out, top) = agg_with({}, [Status("amcl: a", OK)])
    s = by_name(out)
    assert s["/AnalyzerGroup"].level == ERROR and s["/AnalyzerGroup"].message == "No analyzers"
    assert "/Other/amcl: a" in s


def test_nothing_received_toplevel():
    _, (out, top) = agg_with({"analyzers": {"a": {"type": GENERIC, "path": "A", "startswith": "a"}}}, [])
    assert [x.name for x in out] == ["/A"] and out[0].level == STALE
    assert top.level == STALE


# -- bad configuration ----------------------------------------------------------------

def errors_of(analyzers):
    return [str(e) for e in Aggregator({"analyzers": analyzers}, 0.0).errors]


def test_unknown_type_is_named():
    errs = errors_of({"navigation": {"type": "foo/Bar", "path": "N"}})
    assert errs and errs[0].startswith("~analyzers/navigation: unknown type 'foo/Bar'")


def test_bad_analyzer_is_reported_and_the_others_run():
    params = {"analyzers": {"bad": {"type": GENERIC, "path": "Bad"},     # no way of matching
                            "good": {"type": GENERIC, "path": "Good", "startswith": "a"}}}
    agg = Aggregator(params, 0.0)
    assert "~analyzers/bad: GenericAnalyzer 'Bad' has no way of matching" in str(agg.errors[0])
    agg.add([Status("a: x", OK)], 0.0)
    s = by_name(agg.report(0.5)[0])
    assert s["/Good/a: x"].level == OK
    assert s["/bad"].level == STALE and "no way of matching" in s["/bad"].message


@pytest.mark.parametrize("analyzers, text", [
    ({"n": {"type": GENERIC, "path": "N", "startswith": 3}}, "~analyzers/n/startswith: must be a string or a list"),
    ({"n": {"type": GENERIC, "startswith": "a"}}, "~analyzers/n: GenericAnalyzer needs a 'path'"),
    ({"n": {"path": "N", "startswith": "a"}}, "~analyzers/n: no 'type'"),
    ({"n": "GenericAnalyzer"}, "~analyzers/n: must be a dict"),
    ({"n": {"type": GENERIC, "path": "N", "regex": "("}}, "~analyzers/n/regex: '(' is not a regular expression"),
    ({"n": {"type": GENERIC, "path": "N", "startswith": "a", "timeout": "5"}}, "~analyzers/n/timeout: must be a number"),
    ({"n": {"type": GENERIC, "path": "N", "startswith": "a", "discard_stale": "yes"}},
     "~analyzers/n/discard_stale: must be true or false"),
    ({"g": {"type": GROUP, "path": "G", "analyzers": {"x": {"type": "foo/Bar"}}}},
     "~analyzers/g/analyzers/x: unknown type 'foo/Bar'"),
    ({"g": {"type": GROUP, "path": "G", "analyzers": ["x"]}}, "~analyzers/g/analyzers: must be a dict"),
])
def test_bad_parameters_are_named(analyzers, text):
    errs = errors_of(analyzers)
    assert any(e.startswith(text) for e in errs), errs


def test_analyzers_not_a_dict_or_bad_node_parameters_raise():
    with pytest.raises(ConfigError, match="~analyzers: must be a dict"):
        Aggregator({"analyzers": ["a", "b"]}, 0.0)
    with pytest.raises(ConfigError, match="~base_path: must be a string"):
        Aggregator({"base_path": 3}, 0.0)
    with pytest.raises(ConfigError, match="~other_as_errors: must be true or false"):
        Aggregator({"other_as_errors": "no"}, 0.0)


def test_unknown_keys_are_warned():
    said = []
    Aggregator({"analyzers": {"n": {"type": GENERIC, "path": "N", "startwith": "a", "contains": "a"}}}, 0.0,
               warn=said.append)
    assert said == ["~analyzers/n: GenericAnalyzer ignores startwith"]


def test_the_shipped_analyzers_group_every_node_alone_or_in_a_robot_namespace():
    """config/analyzers.yaml (what sim.launch starts) puts each node's statuses under its
    part of the Navigation Stack, and so for a robot of several ("robot_1/amcl: ..."):
    with startswith those went to Other (found in review, multi_robot launch files)."""
    import os
    import yaml
    path = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "config", "analyzers.yaml")
    with open(path) as f:
        params = yaml.safe_load(f)
    parts = {"summit_xl_sim: Battery": "Simulator", "amcl: Standard deviation": "Localization",
             "ekf_se: Filter": "Localization", "slam_gmapping: Map update": "Mapping",
             "slam_karto: Scan rate": "Mapping", "move_base: Controller": "Planning",
             "auto_navigator: Cruise": "Cruise", "patrol: Cruise": "Cruise"}
    for prefix in ("", "robot_1/", "fleet/robot_2/"):
        statuses = [Status(prefix + name, OK, "fine") for name in parts]
        _, (out, _) = agg_with(params, statuses)
        s = by_name(out)
        assert not [n for n in s if n.startswith("/Other")], (prefix, sorted(s))
        for name, part in parts.items():
            matched = [n for n in s if n.startswith(f"/Navigation Stack/{part}/") and n.endswith(name)]
            assert matched, (prefix + name, part, sorted(s))
