"""The plugin registry by type string and move_base's parameters: every one optional."""
import os

import pytest

from my_summit_path_planning import plugins, recovery
from my_summit_path_planning.costmap import Footprint
from my_summit_path_planning.dwa import DWAPlanner
from my_summit_path_planning.nav_core import PluginContext, PluginError, Registry
from my_summit_path_planning.navfn import NavFn
from my_summit_path_planning.params import ParamError, load_move_base_params, move_base_params
from my_summit_path_planning.plugins import GLOBAL_PLANNERS, MoveBasePlugins
from my_summit_path_planning.recovery import ClearCostmapRecovery

CONFIG = os.path.join(os.path.dirname(__file__), "..", "config")
DWA = "dwa_local_planner/DWAPlannerROS"


@pytest.fixture
def footprint():
    return Footprint.from_params([[0.36, 0.31], [-0.36, 0.31], [-0.36, -0.31], [0.36, -0.31]], 0.46, 0.01)


def test_no_parameters_at_all_means_the_real_defaults():
    p = move_base_params({}, "/move_base")
    mb = p.move_base
    assert (mb.base_global_planner, mb.base_local_planner) == ("navfn/NavfnROS", "base_local_planner/TrajectoryPlannerROS")
    assert (mb.planner_frequency, mb.controller_frequency, mb.planner_patience, mb.controller_patience) == \
        (0.0, 20.0, 5.0, 15.0)
    assert (mb.conservative_reset_dist, mb.oscillation_timeout, mb.oscillation_distance, mb.max_planning_retries) == \
        (3.0, 0.0, 0.5, -1)
    assert mb.recovery_behavior_enabled and mb.clearing_rotation_allowed and not mb.shutdown_costmaps
    assert mb.recovery_behaviors is None
    assert (p.global_costmap.global_frame, p.global_costmap.robot_base_frame) == ("map", "base_link")
    assert p.navfn.allow_unknown is True and p.navfn.default_tolerance == 0.0
    assert p.namespaces == {} and p.ignored == ()


def test_ignored_parameters_are_named_when_they_ask_for_something():
    assert move_base_params({"shutdown_costmaps": False}).ignored == ()
    assert move_base_params({"shutdown_costmaps": True, "make_plan_clear_costmap": False}).ignored == \
        ("shutdown_costmaps",)


def test_names_move_base_does_not_read_are_left_unread_and_noted():
    """The real move_base never asks for a name it does not know, so configurations carry
    some and run: navigation_tutorials' move_base.xml sets ~footprint_padding (each costmap
    reads its own), husky_navigation's planner.yaml the misspelt recovery_behaviour_enabled.
    Ours runs too, the costmaps' own values kept, and notes each name once with the
    nearest one it reads."""
    p = move_base_params({"footprint_padding": 0.01, "recovery_behaviour_enabled": False,
                          "global_costmap": {"footprint_padding": 0.02, "meter_scoring": True}})
    assert p.global_costmap.footprint_padding == 0.02
    assert p.move_base.recovery_behavior_enabled is True      # the misspelt name is not read
    assert p.notes == (
        "'footprint_padding' is not a parameter this node reads; ignored",
        "'recovery_behaviour_enabled' is not a parameter this node reads; ignored "
        "(did you mean 'recovery_behavior_enabled'?)")
    assert p.global_costmap.notes[-1] == "'meter_scoring' is not a parameter this node reads; ignored"
    assert p.ignored == ()


def test_missing_planner_namespaces_mean_defaults(footprint):
    p = move_base_params({"base_local_planner": DWA})
    pl = MoveBasePlugins(p, footprint=footprint)
    assert isinstance(pl.global_planner, NavFn) and pl.global_planner.config.allow_unknown is True
    assert isinstance(pl.local_planner, DWAPlanner) and pl.local_planner.config.max_vel_x == 0.55
    assert [n for n, _ in pl.recoveries] == ["conservative_reset", "rotate_recovery", "aggressive_reset",
                                             "rotate_recovery"]
    (_, cons), (_, rot), (_, aggr), _ = pl.recoveries
    # move_base's aggressive reset: 4 x ~local_costmap/circumscribed_radius (0.46 m), not the footprint's
    assert cons.reset_distance == 3.0 and aggr.reset_distance == pytest.approx(4 * 0.46)
    p = move_base_params({"base_local_planner": DWA, "local_costmap": {"circumscribed_radius": 0.5}})
    aggr = dict(MoveBasePlugins(p, footprint=footprint).recoveries)["aggressive_reset"]
    assert aggr.reset_distance == pytest.approx(2.0)
    assert rot.max_rotational_vel == 1.0 and rot.acc_lim_th == 3.2     # DWA's defaults
    assert pl.goal_tolerance() == (True, 0.0)
    assert pl.make_local_planner() is not pl.local_planner


def test_trajectory_planner_default_is_named_when_absent(footprint):
    """move_base's default local planner: built when trajectory_planner is in the build,
    else an error that says what is missing and what to set."""
    try:
        import my_summit_path_planning.trajectory_planner  # noqa: F401
    except ModuleNotFoundError:
        with pytest.raises(PluginError, match=r"base_local_planner: base_local_planner/TrajectoryPlannerROS is not "
                                              r"available in this build \(its module my_summit_path_planning."
                                              r"trajectory_planner is missing\); set base_local_planner to one of: "
                                              r"dwa_local_planner/DWAPlannerROS"):
            MoveBasePlugins(move_base_params({}), footprint=footprint)
    else:
        pl = MoveBasePlugins(move_base_params({}), footprint=footprint)
        assert pl.local_type == "base_local_planner/TrajectoryPlannerROS" and pl.local_name == "TrajectoryPlannerROS"


def test_course_config_unchanged(footprint):
    p = load_move_base_params(CONFIG)
    pl = MoveBasePlugins(p, footprint=footprint)
    assert (pl.global_name, pl.local_name) == ("NavfnROS", "DWAPlannerROS")
    assert pl.global_planner.config.allow_unknown is False and pl.goal_tolerance() == (False, 0.2)
    assert pl.local_planner.config.max_vel_x == 1.0 and pl.local_planner.config.vth_samples == 40
    rot = pl.recoveries[1][1]
    assert (rot.max_rotational_vel, rot.acc_lim_th, rot.min_in_place_rotational_vel) == (3.0, 5.0, 0.3)
    assert rot.frequency == 20.0


@pytest.mark.parametrize("ns,match", [
    ({"planner_patience": "5"}, r"/move_base: 'planner_patience' must be float, got '5'"),
    ({"recovery_behavior_enabled": 1}, r"'recovery_behavior_enabled' must be bool"),
    ({"max_planning_retries": 2.5}, r"'max_planning_retries' must be int"),
    ({"base_global_planner": 3}, r"'base_global_planner' must be str"),
    ({"recovery_behaviors": "rotate"}, r"'recovery_behaviors' must be a list"),
    ({"global_costmap": {"resolution": "fine"}}, r"/move_base/global_costmap: 'resolution' must be float"),
])
def test_wrong_types_fail_at_once_naming_the_parameter(ns, match):
    with pytest.raises(ParamError, match=match):
        move_base_params(ns, "/move_base")


@pytest.mark.parametrize("ns,match", [
    ({"NavfnROS": {"allow_unknown": "yes"}}, r"NavfnROS: 'allow_unknown' must be bool"),
    ({"DWAPlannerROS": {"vx_samples": "many"}}, r"DWAPlannerROS: 'vx_samples' must be int"),
    ({"base_global_planner": "sbpl_lattice_planner/SBPLLatticePlanner"},
     r"base_global_planner: unknown type 'sbpl_lattice_planner/SBPLLatticePlanner'; known types are: "
     r"carrot_planner/CarrotPlanner, global_planner/GlobalPlanner, navfn/NavfnROS"),
    ({"base_local_planner": "teb_local_planner/TebLocalPlannerROS"},
     r"known types are: .*dwa_local_planner/DWAPlannerROS"),
])
def test_plugin_errors_are_named(ns, match, footprint):
    with pytest.raises(ParamError, match=match):
        MoveBasePlugins(move_base_params({"base_local_planner": DWA, **ns}), footprint=footprint)


def test_bare_class_name_resolves_with_a_warning(footprint):
    said = []
    pl = MoveBasePlugins(move_base_params({"base_global_planner": "NavfnROS", "base_local_planner": "DWAPlannerROS"}),
                         footprint=footprint, warn=said.append)
    assert (pl.global_type, pl.local_type) == ("navfn/NavfnROS", DWA)
    assert len(said) == 2 and "'navfn/NavfnROS'" in said[0]


def test_unused_planner_namespaces_are_left_alone(footprint):
    """Another planner's namespace (a config shared between setups) is not read."""
    p = move_base_params({"base_local_planner": DWA, "TrajectoryPlannerROS": {"whatever": 1},
                          "GlobalPlanner": {"use_dijkstra": "no"}})
    assert isinstance(MoveBasePlugins(p, footprint=footprint).local_planner, DWAPlanner)


def test_a_bad_recovery_list_falls_back_to_the_defaults_with_its_reason(footprint):
    p = move_base_params({"base_local_planner": DWA,
                          "recovery_behaviors": [{"name": "pace", "type": "pace_recovery/PaceRecovery"}]})
    pl = MoveBasePlugins(p, footprint=footprint)
    assert "unknown type 'pace_recovery/PaceRecovery'" in pl.recovery_error
    assert "rotate_recovery/RotateRecovery" in pl.recovery_error
    assert [n for n, _ in pl.recoveries][0] == "conservative_reset"
    p = move_base_params({"base_local_planner": DWA, "clearing_rotation_allowed": False,
                          "conservative_reset": {"layer_names": ["obstacles"]}})
    seq = MoveBasePlugins(p, footprint=footprint).recoveries
    assert [n for n, _ in seq] == ["conservative_reset", "aggressive_reset"]
    assert seq[0][1].layer_names == ("obstacles",) and seq[0][1].reset_distance == 3.0


def test_registry_checks_the_interface_and_the_form():
    reg = Registry("base_local_planner")
    reg.register("fake/Half", lambda params, ctx, where: object())
    with pytest.raises(PluginError, match=r"object lacks set_plan, compute_velocity_commands"):
        reg.create("fake/Half", {}, PluginContext(), "Half")
    with pytest.raises(ValueError, match="package/Class"):
        reg.register("Half", lambda *a: None)
    with pytest.raises(PluginError, match="expected a namespace"):
        reg.create("fake/Half", [1, 2], PluginContext(), "Half")


def test_a_planner_registers_in_one_line(footprint):
    """As global_planner.GlobalPlanner will: from_params(params, where) with NavFn's make_plan."""

    class Straight:
        def __init__(self, step):
            self.step = step

        @classmethod
        def from_params(cls, params, where):
            return cls(params.get("step", 0.5))

        def make_plan(self, costmap, start, goal, tolerance=None):
            return NavFn().make_plan(costmap, start, goal, tolerance)

    GLOBAL_PLANNERS.register("test_planners/Straight", lambda params, ctx, where: Straight.from_params(params, where))
    try:
        pl = MoveBasePlugins(move_base_params({"base_global_planner": "test_planners/Straight",
                                               "base_local_planner": DWA, "Straight": {"step": 0.25}}),
                             footprint=footprint)
        assert isinstance(pl.global_planner, Straight) and pl.global_planner.step == 0.25
        assert pl.global_name == "Straight"
    finally:
        del GLOBAL_PLANNERS.plugins["test_planners/Straight"]


def test_trajectory_planner_limits_read_as_rotate_recovery_does():
    lim = plugins.trajectory_planner_limits({"max_rotational_vel": 2.0, "acc_lim_theta": 4.0,
                                             "min_in_place_vel_theta": 0.5})
    assert lim == {"acc_lim_th": 4.0, "max_rotational_vel": 2.0, "min_in_place_rotational_vel": 0.5,
                   "yaw_goal_tolerance": 0.05, "acc_lim_x": 2.5}
    with pytest.raises(PluginError, match="'acc_lim_theta' must be float"):
        plugins.trajectory_planner_limits({"acc_lim_theta": "fast"})


def test_clear_costmap_clears_each_costmap_around_its_own_pose(footprint, costmap_handle):
    from my_summit_path_planning import cost_values as cv
    from my_summit_path_planning.costmap import Costmap2D, LayeredCostmap

    def layered():
        lc = LayeredCostmap.from_plugins([{"name": "obstacle_layer", "type": "costmap_2d::ObstacleLayer"}],
                                         {"obstacle_layer": {"observation_sources": ""}},
                                         Costmap2D(200, 200, 0.05, -5.0, -5.0), footprint)
        lc.layer("obstacle_layer").grid.data[:] = cv.LETHAL_OBSTACLE
        return lc

    g, loc = layered(), layered()
    rec = ClearCostmapRecovery(costmap_handle(g, (2.0, 0.0, 0.0)), costmap_handle(loc, (0.0, 0.0, 0.0)),
                               reset_distance=1.0, layer_names=("obstacle_layer",))
    rec.start((0.0, 0.0, 0.0))
    assert rec.step((0.0, 0.0, 0.0)).done and rec.cleared == ["obstacle_layer", "obstacle_layer"]
    for lc, (x, y) in ((g, (2.0, 0.0)), (loc, (0.0, 0.0))):
        lc.update_map(x, y, 0.0)
        assert lc.master.cost_at(x + 0.45, y) == cv.LETHAL_OBSTACLE       # kept inside the square
        assert lc.master.cost_at(x - 1.0, y) == cv.FREE_SPACE             # cleared outside


def _lethal_obstacle_costmap(footprint, name="obstacle_layer"):
    from my_summit_path_planning import cost_values as cv
    from my_summit_path_planning.costmap import Costmap2D, LayeredCostmap
    lc = LayeredCostmap.from_plugins([{"name": name, "type": "costmap_2d::ObstacleLayer"}],
                                     {name: {"observation_sources": ""}},
                                     Costmap2D(200, 200, 0.05, -5.0, -5.0), footprint)
    lc.layer(name).grid.data[:] = cv.LETHAL_OBSTACLE
    return lc


def test_clear_costmap_recovery_takes_the_real_nodes_parameters(footprint, costmap_handle):
    """clear_costmap_recovery (noetic) reads layer_names (default [obstacles]: the course's
    obstacle_layer is then not cleared, in the real node too), invert_area_to_clear,
    affected_maps and force_updating. Ours read only the first, with [obstacle_layer] as
    its default, and left the others unread: a config asking to clear only the local
    costmap, or inside the square, cleared both, outside."""
    from my_summit_path_planning import cost_values as cv
    ctx = PluginContext(footprint=footprint)

    def build(params, names=("obstacle_layer", "obstacle_layer")):
        g = _lethal_obstacle_costmap(footprint, names[0])
        loc = _lethal_obstacle_costmap(footprint, names[1])
        ctx.global_costmap = costmap_handle(g, (0.0, 0.0, 0.0), "global_costmap")
        ctx.local_costmap = costmap_handle(loc, (0.0, 0.0, 0.0), "local_costmap")
        beh = plugins.RECOVERY_BEHAVIORS.create(recovery.CLEAR_TYPE, dict(params), ctx, "reset")
        beh.start((0.0, 0.0, 0.0))
        beh.step((0.0, 0.0, 0.0))
        # each obstacle layer's own cells (the master is redrawn only where layers changed)
        return beh, g.layers[0].grid, loc.layers[0].grid

    # The default names miss obstacle_layer: nothing cleared, and a note says why.
    beh, g, loc = build({"reset_distance": 1.0})
    assert beh.cleared == [] and g.cost_at(-3.0, 0.0) == cv.LETHAL_OBSTACLE
    assert any("it will clear nothing there" in n and "global_costmap" in n for n in beh.notes)
    beh, g, loc = build({"reset_distance": 1.0}, ("obstacles", "obstacles"))
    assert beh.cleared == ["obstacles", "obstacles"] and beh.notes == []
    # invert_area_to_clear: inside the square cleared, outside kept.
    beh, g, loc = build({"reset_distance": 1.0, "layer_names": ["obstacle_layer"], "invert_area_to_clear": True})
    assert g.cost_at(0.2, 0.0) == cv.FREE_SPACE and g.cost_at(-3.0, 0.0) == cv.LETHAL_OBSTACLE
    # affected_maps: only the one named; a wrong value warns as the real one and clears both.
    beh, g, loc = build({"reset_distance": 1.0, "layer_names": ["obstacle_layer"], "affected_maps": "local"})
    assert g.cost_at(-3.0, 0.0) == cv.LETHAL_OBSTACLE and loc.cost_at(-3.0, 0.0) == cv.FREE_SPACE
    beh, g, loc = build({"reset_distance": 1.0, "layer_names": ["obstacle_layer"], "affected_maps": "global"})
    assert g.cost_at(-3.0, 0.0) == cv.FREE_SPACE and loc.cost_at(-3.0, 0.0) == cv.LETHAL_OBSTACLE
    beh, g, loc = build({"reset_distance": 1.0, "layer_names": ["obstacle_layer"], "affected_maps": "al"})
    assert g.cost_at(-3.0, 0.0) == cv.FREE_SPACE and loc.cost_at(-3.0, 0.0) == cv.FREE_SPACE
    assert any("Wrong value for affected_maps parameter: 'al'" in n for n in beh.notes)
    with pytest.raises(PluginError, match="'invert_area_to_clear' must be bool"):
        build({"invert_area_to_clear": "yes"})


def test_clear_costmap_force_updating_updates_at_once(footprint, costmap_handle):
    updated = []

    class Handle(costmap_handle):
        def update(self):
            updated.append(self.name)

    g = _lethal_obstacle_costmap(footprint)
    for force, expect in ((False, []), (True, ["global_costmap"])):
        updated.clear()
        rec = ClearCostmapRecovery(Handle(g, (0.0, 0.0, 0.0), "global_costmap"), None, reset_distance=1.0,
                                   layer_names=("obstacle_layer",), force_updating=force)
        rec.step((0.0, 0.0, 0.0))
        assert updated == expect


def test_planner_notes_name_unused_and_deprecated_parameters(footprint):
    """A parameter the real planner accepts but ours does not use is said once, by name."""
    pl = MoveBasePlugins(move_base_params({
        "base_global_planner": "global_planner/GlobalPlanner",
        "base_local_planner": "base_local_planner/TrajectoryPlannerROS",
        "GlobalPlanner": {"no_such_knob": 1},
        "TrajectoryPlannerROS": {"pdist_scale": 0.6, "no_such_knob": 2}}), footprint=footprint)
    assert "~GlobalPlanner: 'no_such_knob' is not a parameter this node reads; ignored" in pl.notes
    assert "~TrajectoryPlannerROS: 'no_such_knob' is not a parameter this node reads; ignored" in pl.notes
    assert any("pdist_scale" in n for n in pl.notes if "ignored" not in n)


def test_dwa_says_once_that_it_does_not_scale_the_footprint_with_speed(footprint):
    """dwa_local_planner checks each trajectory with the footprint scaled up with its speed
    (scaling_speed, max_scaling_factor: on by default); ours checks it unscaled, and says so
    once, with the values, rather than dropping the parameters silently (use_dwa false too)."""
    dwa = {"base_local_planner": "dwa_local_planner/DWAPlannerROS"}
    pl = MoveBasePlugins(move_base_params({**dwa, "DWAPlannerROS": {"max_scaling_factor": 0.3, "use_dwa": False}}),
                         footprint=footprint)
    scaling = [n for n in pl.notes if "speed scaling" in n]
    assert len(scaling) == 1 and "max_scaling_factor 0.3" in scaling[0] and "x1.3" in scaling[0]
    assert any("use_dwa false is ignored" in n for n in pl.notes)
    pl = MoveBasePlugins(move_base_params(dwa), footprint=footprint)
    assert not any("use_dwa" in n for n in pl.notes) and any("x1.2" in n for n in pl.notes)


def test_dwa_reads_no_old_name_as_dwa_local_planner(footprint):
    """DWAPlannerROS::initialize warns for six renamed parameters whenever the old name is
    set ("will not load properly": nav_core::warnRenamedParameter copies nothing) and reads
    only the new names; base_local_planner's acc_lim_th and vtheta_samples mean nothing there
    (husky_navigation's DWAPlannerROS sets acc_lim_th). dynamic_reconfigure raises a sample
    count below its minimum, 1 (turtlebot3_navigation sets vy_samples: 0)."""
    params = {"max_rot_vel": 2.0, "min_rot_vel": 0.3, "acc_limit_trans": 1.0, "max_trans_vel": 0.4,
              "max_vel_trans": 0.5, "acc_lim_th": 9.0, "vtheta_samples": 40, "vy_samples": 0}
    pl = MoveBasePlugins(move_base_params({"base_local_planner": DWA, "DWAPlannerROS": params}),
                         footprint=footprint)
    c = pl.local_planner.config
    assert (c.max_vel_theta, c.min_vel_theta, c.acc_lim_trans) == (1.0, 0.4, 0.0)     # the defaults
    assert c.max_vel_trans == 0.5
    assert (c.acc_lim_theta, c.vth_samples, c.vy_samples) == (3.2, 20, 1)
    notes = "\n".join(pl.notes)
    for old, new in (("max_rot_vel", "max_vel_theta"), ("max_trans_vel", "max_vel_trans")):
        assert f"Parameter {old} is deprecated (and will not load properly). Use {new} instead." in notes
    assert "DWAPlannerROS: 'acc_lim_th' is not a parameter this node reads; ignored" in notes
    assert "'max_rot_vel' is not a parameter" not in notes        # the real warning, not ours
    assert "DWAPlannerROS: 'vy_samples' 0 raised to 1" in notes


def test_course_config_default_recoveries_clear_its_obstacle_layer(footprint, costmap_handle):
    """The course's costmaps name their obstacle layer obstacle_layer, which the real
    default layer_names ([obstacles]) misses; move_base_params.yaml names it for both
    default resets, so they clear it and say nothing at start."""
    p = load_move_base_params(os.path.join(os.path.dirname(__file__), "..", "config"))
    g = _lethal_obstacle_costmap(footprint)
    pl = MoveBasePlugins(p, costmap_handle(g, (0.0, 0.0, 0.0), "global_costmap"),
                         costmap_handle(_lethal_obstacle_costmap(footprint), (0.0, 0.0, 0.0), "local_costmap"))
    resets = {n: b for n, b in pl.recoveries if isinstance(b, ClearCostmapRecovery)}
    assert sorted(resets) == ["aggressive_reset", "conservative_reset"]
    assert all(b.layer_names == ("obstacle_layer",) for b in resets.values())
    assert not [n for n in pl.notes if "clear nothing" in n]
