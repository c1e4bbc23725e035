"""The driving layer's import rules (docs/driving_layer.md), checked by parsing the imports.

A planner module (one file per nav_core plugin: dwa, trajectory_planner, navfn,
global_planner, carrot_planner) imports no other planner's module: what two planners
share lives in a module named for what it holds (local_plan, latency, clearance,
oscillation, goal_approach, footprint_cost, global_plan). The pure package imports no
rospy: the ROS side lives in its ros subpackage (costmap_ros, sensor_hub, reconfigure),
which no pure module imports; the shared modules import no planner.
"""
import ast
import os

import pytest

PKG = os.path.join(os.path.dirname(__file__), "..", "src", "my_summit_path_planning")
PLANNERS = {"dwa", "trajectory_planner", "navfn", "global_planner", "carrot_planner"}
SHARED = {"local_plan", "latency", "clearance", "oscillation", "goal_approach", "footprint_cost", "global_plan"}
ROS = {"rospy", "dynamic_reconfigure", "tf2_ros", "actionlib"}
ROS_SUBPACKAGE = "ros"


def package_imports(module):
    """The package's modules `module` imports (relative or absolute), at any depth of its code."""
    tree = ast.parse(open(os.path.join(PKG, module + ".py")).read())
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            if node.level == 1 and node.module:
                out.add(node.module.split(".")[0])
            elif node.level == 1:
                out.update(a.name for a in node.names)
            elif node.module and node.module.startswith("my_summit_path_planning."):
                out.add(node.module.split(".")[1])
            elif node.module == "my_summit_path_planning":
                out.update(a.name for a in node.names)
        elif isinstance(node, ast.Import):
            for a in node.names:
                if a.name.startswith("my_summit_path_planning."):
                    out.add(a.name.split(".")[1])
    return out


def top_imports(module):
    """The top-level names of every module `module` (a path under the package, no .py) imports."""
    tree = ast.parse(open(os.path.join(PKG, module + ".py")).read())
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names.update(a.name.split(".")[0] for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names.add(node.module.split(".")[0])
    return names


def modules():
    return sorted(f[:-3] for f in os.listdir(PKG) if f.endswith(".py") and f != "__init__.py")


def test_the_lists_name_existing_modules():
    assert PLANNERS | SHARED <= set(modules())


@pytest.mark.parametrize("planner", sorted(PLANNERS))
def test_no_planner_module_imports_another_planners_module(planner):
    others = (package_imports(planner) & PLANNERS) - {planner}
    assert not others, f"{planner} imports planner module(s) {sorted(others)}: move what they share out"


@pytest.mark.parametrize("module", sorted(SHARED))
def test_shared_modules_import_no_planner(module):
    assert not package_imports(module) & PLANNERS


def ros_modules():
    folder = os.path.join(PKG, ROS_SUBPACKAGE)
    return sorted(f"{ROS_SUBPACKAGE}/{f[:-3]}" for f in os.listdir(folder) if f.endswith(".py"))


@pytest.mark.parametrize("module", modules())
def test_the_pure_package_imports_no_rospy(module):
    assert not top_imports(module) & ROS


@pytest.mark.parametrize("module", modules())
def test_no_pure_module_imports_the_ros_subpackage(module):
    assert ROS_SUBPACKAGE not in package_imports(module)


def test_the_ros_side_is_in_the_ros_subpackage():
    """costmap_ros, sensor_hub and reconfigure import ROS and live in ros/; the check sees them."""
    mods = ros_modules()
    assert {"ros/costmap_ros", "ros/sensor_hub", "ros/reconfigure"} <= set(mods)
    assert all(top_imports(m) & ROS for m in ("ros/costmap_ros", "ros/sensor_hub", "ros/reconfigure"))
    assert not top_imports("ros/__init__") & ROS      # importing the subpackage loads nothing


def test_the_check_sees_a_planner_import():
    """The parser is not blind: plugins imports dwa (it registers the planners)."""
    assert "dwa" in package_imports("plugins") and "global_planner" in package_imports("plugins")


def test_param_reader_imports_no_module_of_the_package():
    """Every module reads its parameters through param_reader: it must depend on none of them."""
    assert package_imports("param_reader") == set()
