"""costmap_2d's pre-Hydro layout translated as loadOldParameters does; the plugin layout kept.

The lesson's files (config/navigation_stage/) are navigation_tutorials' real
navigation_stage costmap files, loaded as its move_base.xml loads them.
"""
import os

import numpy as np
import pytest
import yaml

from my_summit_path_planning import cost_values as cv
from my_summit_path_planning import costmap_params as cp
from my_summit_path_planning import params as mb_params
from my_summit_path_planning.layers import InflationLayer, ObstacleLayer, StaticLayer, VoxelLayer, \
    scan_to_observation

HERE = os.path.dirname(os.path.abspath(__file__))
LESSON = os.path.join(HERE, "..", "config", "navigation_stage")
COURSE_CONFIG = os.path.join(HERE, "..", "config")


def _yaml(path, tf_prefix=""):
    with open(path) as f:
        # move_base.xml loads with subst_value="True"; its tf_prefix argument defaults to ''.
        return yaml.safe_load(f.read().replace("$(arg tf_prefix)", tf_prefix))


def lesson_namespaces():
    """{costmap name: namespace} as the lesson's move_base.xml puts them on the parameter server."""
    common = _yaml(os.path.join(LESSON, "costmap_common_params.yaml"))
    out = {}
    for ns in ("global_costmap", "local_costmap"):
        own = _yaml(os.path.join(LESSON, f"{ns.split('_')[0]}_costmap_params.yaml"))[ns]
        out[ns] = mb_params._deep_merge(common, own)
    return out


def build(ns_name, ns):
    logged = []
    cfg = mb_params.costmap_config(ns, ns_name)
    lc = mb_params.build_costmap(cfg, ns_name, log=logged.append)
    return cfg, lc, logged


def test_lesson_global_costmap_translates_as_costmap_2d():
    plugins, ns = cp.pre_hydro_to_plugins(lesson_namespaces()["global_costmap"])
    assert plugins == [{"name": "static_layer", "type": "costmap_2d::StaticLayer"},
                       {"name": "obstacle_layer", "type": "costmap_2d::VoxelLayer"},
                       {"name": "inflation_layer", "type": "costmap_2d::InflationLayer"}]
    assert ns["static_layer"] == {"lethal_cost_threshold": 100}
    assert ns["obstacle_layer"] == {
        "origin_z": 0.0, "z_resolution": 0.2, "z_voxels": 10, "unknown_threshold": 9, "mark_threshold": 0,
        "max_obstacle_height": 2.0, "obstacle_range": 2.5, "raytrace_range": 3.0,
        "observation_sources": "base_scan",
        "base_scan": {"data_type": "LaserScan", "expected_update_rate": 0.4, "observation_persistence": 0.0,
                      "marking": True, "clearing": True, "max_obstacle_height": 0.4,
                      "min_obstacle_height": 0.08}}
    assert ns["inflation_layer"] == {"inflation_radius": 0.55, "cost_scaling_factor": 10.0}
    # What stays at the top level is the costmap's own (and the two pre-Hydro flags).
    assert sorted(k for k in ns if not isinstance(ns[k], dict)) == sorted([
        "map_type", "transform_tolerance", "footprint", "footprint_padding", "global_frame",
        "robot_base_frame", "update_frequency", "publish_frequency", "static_map", "rolling_window"])


def test_lesson_local_costmap_translates_as_costmap_2d():
    plugins, ns = cp.pre_hydro_to_plugins(lesson_namespaces()["local_costmap"])
    assert [p["type"] for p in plugins] == ["costmap_2d::VoxelLayer", "costmap_2d::InflationLayer"]
    assert ns["obstacle_layer"]["publish_voxel_map"] is True
    assert "static_layer" not in ns
    # Without a static layer nothing takes lethal_cost_threshold: costmap_2d leaves it unread.
    assert ns["lethal_cost_threshold"] == 100


def test_lesson_costmaps_build_with_costmap_2d_warnings():
    spaces = lesson_namespaces()
    cfg, lc, logged = build("global_costmap", spaces["global_costmap"])
    assert [type(l) for l in lc.layers] == [StaticLayer, VoxelLayer, InflationLayer]
    assert logged[0] == 'global_costmap: Parameter "plugins" not provided, loading pre-Hydro parameters'
    assert any("'unknown_threshold' has no meaning for a 2D costmap; ignored" in m for m in logged)
    assert cfg.global_frame == "/map" and cfg.transform_tolerance == 0.3 and cfg.publish_frequency == 0.0
    static, voxel, inflation = lc.layers
    assert static.lethal_cost_threshold == 100 and static.track_unknown_space  # StaticLayer's default
    assert not voxel.track_unknown_space                                      # the costmap's default
    assert voxel.top_z == pytest.approx(2.0) and voxel.max_obstacle_height == 2.0
    src = voxel.sources["base_scan"]
    assert (src["topic"], src["marking"], src["clearing"]) == ("base_scan", True, True)
    assert (src["min_obstacle_height"], src["max_obstacle_height"]) == (0.08, 0.4)
    assert (src["obstacle_range"], src["raytrace_range"]) == (2.5, 3.0)
    assert (inflation.inflation_radius, inflation.cost_scaling_factor) == (0.55, 10.0)
    assert lc.footprint.padding == 0.02
    # costmap_2d's padFootprint moves each vertex 0.02 m outward along x and y.
    assert lc.footprint.circumscribed_radius == pytest.approx(np.hypot(0.345, 0.345))

    cfg, lc, logged = build("local_costmap", spaces["local_costmap"])
    assert [type(l) for l in lc.layers] == [VoxelLayer, InflationLayer]
    assert cfg.rolling_window and (lc.master.size_x, lc.master.size_y) == (240, 240)
    assert lc.master.resolution == 0.025 and cfg.global_frame == "odom"
    assert any("'lethal_cost_threshold' at the costmap's top level is read by no layer" in m for m in logged)
    assert any("'publish_voxel_map' has no meaning" in m for m in logged)
    assert len(logged) == len(set(logged))


def _wall_scan(z):
    """A level laser at the origin, height z [m], seeing a wall 1 m ahead (9 beams)."""
    return scan_to_observation(np.full(9, 1.0), -0.2, 0.05, 0.1, 30.0, (0.0, 0.0, 0.0), sensor_z=z,
                               min_obstacle_height=0.08, max_obstacle_height=0.4, source="base_scan")


def _lethal_cells(lc):
    return int((lc.master.data == cv.LETHAL_OBSTACLE).sum())


def test_voxel_layer_laser_above_max_obstacle_height_marks_nothing():
    ns = lesson_namespaces()["local_costmap"]
    # The Summit XL's Hokuyo sits 0.43 m up: above base_scan's max_obstacle_height 0.4.
    _, lc, logged = build("local_costmap", ns)
    lc.layer("obstacle_layer").add_observation(_wall_scan(0.43))
    lc.update_map(0.0, 0.0, 0.0)
    assert _lethal_cells(lc) == 0
    assert any("z = 0.430 m, outside the source's [min_obstacle_height, max_obstacle_height] = "
               "[0.08, 0.4] m" in m for m in logged)
    # The same scan from within the band marks the wall.
    lc.layer("obstacle_layer").add_observation(_wall_scan(0.3))
    lc.update_map(0.0, 0.0, 0.0)
    assert _lethal_cells(lc) > 0


def test_voxel_layer_height_band_and_layer_max_height():
    ns = lesson_namespaces()["local_costmap"]
    ns["base_scan"] = dict(ns["base_scan"], max_obstacle_height=5.0)
    ns["z_voxels"] = 1                 # voxel grid [0, 0.2) m
    _, lc, logged = build("local_costmap", ns)
    layer = lc.layer("obstacle_layer")
    layer.add_observation(_wall_scan(0.3))
    lc.update_map(0.0, 0.0, 0.0)
    assert _lethal_cells(lc) == 0
    assert any("outside the voxel grid's" in m and "mark and clear nothing" in m for m in logged)
    layer.add_observation(_wall_scan(0.1))
    lc.update_map(0.0, 0.0, 0.0)
    assert _lethal_cells(lc) > 0
    # The layer's own max_obstacle_height: a plain obstacle layer above it marks nothing.
    ns = lesson_namespaces()["local_costmap"]
    ns["map_type"] = "costmap"
    ns["max_obstacle_height"] = 0.25
    _, lc, logged = build("local_costmap", ns)
    assert type(lc.layers[0]) is ObstacleLayer
    lc.layer("obstacle_layer").add_observation(_wall_scan(0.3))
    lc.update_map(0.0, 0.0, 0.0)
    assert _lethal_cells(lc) == 0
    assert any("above the layer's max_obstacle_height 0.25 m" in m for m in logged)


def test_scan_without_height_is_not_height_filtered():
    _, lc, _ = build("local_costmap", lesson_namespaces()["local_costmap"])
    obs = scan_to_observation(np.full(9, 1.0), -0.2, 0.05, 0.1, 30.0, (0.0, 0.0, 0.0))
    lc.layer("obstacle_layer").add_observation(obs)
    lc.update_map(0.0, 0.0, 0.0)
    assert _lethal_cells(lc) > 0


def test_course_plugin_layout_unchanged():
    p = mb_params.load_move_base_params(COURSE_CONFIG)
    with open(os.path.join(COURSE_CONFIG, "global_costmap_params.yaml")) as f:
        raw = yaml.safe_load(f)["global_costmap"]
    with open(os.path.join(COURSE_CONFIG, "costmap_common_params.yaml")) as f:
        common = yaml.safe_load(f)
    assert p.global_costmap.plugins == raw["plugins"]
    # Only track_unknown_space, given at the top level, is copied (same value) into the layers.
    expected = mb_params._deep_merge(common, raw)
    for name in ("static_layer", "obstacle_layer", "inflation_layer"):
        want = dict(expected[name])
        if name in ("static_layer", "obstacle_layer"):
            want["track_unknown_space"] = raw["track_unknown_space"]
        assert p.global_costmap.layer_params[name] == want
    assert p.global_costmap.notes == ['Pre-Hydro parameter "static_map" unused since "plugins" is provided']
    assert p.local_costmap.layer_params["obstacle_layer"] == common["obstacle_layer"]


def test_plugin_layout_copies_parent_params_over_the_layers():
    ns = {"plugins": [{"name": "inflation", "type": "costmap_2d::InflationLayer"}],
          "inflation": {"inflation_radius": 0.3}, "inflation_radius": 0.7, "cost_scaling_factor": 3.0,
          "obstacle_range": 2.0}
    cfg = mb_params.costmap_config(ns, "c")
    assert cfg.layer_params["inflation"] == {"inflation_radius": 0.7, "cost_scaling_factor": 3.0}
    assert cfg.notes == ["parameter 'obstacle_range' at the costmap's top level is read by no layer "
                         "of this costmap; ignored"]


def test_top_level_keys_of_a_pre_hydro_costmap_never_crash():
    ns = {"transform_tolerance": 0.4, "update_frequency": 3.0, "publish_frequency": 1.0,
          "rolling_window": True, "width": 4.0, "height": 3.0, "resolution": 0.1, "origin_x": 1.0,
          "origin_y": -1.0, "robot_radius": 0.3, "footprint_padding": 0.0, "global_frame": "odom",
          "robot_base_frame": "base_footprint", "static_map": False, "map_type": "costmap",
          "lethal_cost_threshold": 90, "track_unknown_space": True, "unknown_cost_value": 255,
          "map_topic": "map", "publish_voxel_map": False, "z_voxels": 4}
    cfg, lc, logged = build("c", ns)
    assert (lc.master.size_x, lc.master.size_y, lc.master.resolution) == (40, 30, 0.1)
    assert lc.master.default_value == cv.NO_INFORMATION and lc.layers[0].track_unknown_space
    assert lc.footprint.inscribed_radius == pytest.approx(0.3)
    ignored = sorted(m.split("'")[1] for m in logged if m.endswith("ignored"))
    assert ignored == ["lethal_cost_threshold", "map_topic", "publish_voxel_map", "unknown_cost_value",
                       "z_voxels"]
    # With static_map the static layer takes them.
    cfg, lc, logged = build("c", dict(ns, static_map=True, rolling_window=False))
    static = lc.layer("static_layer")
    assert (static.lethal_cost_threshold, static.unknown_cost_value, static.track_unknown_space) == (90, 255, True)


@pytest.mark.parametrize("key, value, words", [
    ("map_type", "octree", "'map_type' must be one of voxel, costmap"),
    ("static_map", "yes", "'static_map' must be true or false"),
    ("observation_sources", ["a"], "'observation_sources' must be a space-separated string"),
    ("z_voxels", 17, "'z_voxels' must be an integer in [0, 16]"),
    ("z_resolution", 0.0, "'z_resolution' must be > 0"),
])
def test_bad_pre_hydro_values_name_the_parameter(key, value, words):
    ns = dict(lesson_namespaces()["local_costmap"], **{key: value})
    with pytest.raises(mb_params.ParamError) as e:
        build("local_costmap", ns)
    assert words in str(e.value) and "local_costmap" in str(e.value)
