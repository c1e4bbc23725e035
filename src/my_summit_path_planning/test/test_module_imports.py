"""The driving layer's import rules (docs/driving_layer.md), checked by parsing the imports.

A planner module (one file per nav_core plugin: dwa, trajectory_planner, navfn,
global_planner, carrot_planner) imports no other planner's module: what two planners
share lives in a module named for what it holds (local_plan, latency, clearance,
oscillation, goal_rotation, footprint_cost, global_plan). The pure package imports no
rospy (reconfigure_ros aside, until it moves into the ros subpackage); the shared
modules import no planner.
"""
import ast
import os

import pytest

PKG = os.path.join(os.path.dirname(__file__), "..", "src", "my_summit_path_planning")
PLANNERS = {"dwa", "trajectory_planner", "navfn", "global_planner", "carrot_planner"}
SHARED = {"local_plan", "latency", "clearance", "oscillation", "goal_rotation", "footprint_cost", "global_plan"}
ROS_ALLOWED = {"reconfigure_ros"}


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


@pytest.mark.parametrize("module", sorted(set(modules()) - ROS_ALLOWED))
def test_the_pure_package_imports_no_rospy(module):
    assert not top_imports(module) & {"rospy", "dynamic_reconfigure", "tf2_ros", "actionlib"}


def test_only_the_listed_modules_import_ros():
    """reconfigure_ros is the one ROS module left in the pure package (issue 43 moves it
    into a ros subpackage); the list must name only modules that exist and do import ROS."""
    for module in ROS_ALLOWED:
        assert module in modules()
        assert top_imports(module) & {"rospy", "dynamic_reconfigure", "tf2_ros", "actionlib"}


def test_the_check_sees_a_planner_import():
    """The parser is not blind: plugins imports dwa (it registers the planners)."""
    assert "dwa" in package_imports("plugins") and "global_planner" in package_imports("plugins")
