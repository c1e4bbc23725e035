"""Each package.xml declares what its package imports and starts, and the workspace's
packages depend on each other one way (SPEC.md: navigation -> path_planning ->
localization -> mapping -> base; the simulator on the base only).

Imports are read with ast from the package's library (src/), executables (nodes/,
scripts/) and tests (test/); launch files give the packages they start or include. A
runtime import must be an exec_depend (a test's may be a test_depend), named by its
rosdep key (python3-numpy, ...) or its ROS package.
"""
import ast
import glob
import os
import re
import sys
import xml.etree.ElementTree as ET

import pytest

WS = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SRC = os.path.join(WS, "src")
PACKAGES = sorted(os.path.basename(os.path.dirname(p)) for p in glob.glob(os.path.join(SRC, "*", "package.xml")))
BASE = "summit_nav_common"
SIM = "summit_xl_sim"
# The course's include chain, lowest first: a package imports only packages before it.
CHAIN = [BASE, "my_summit_mapping", "my_summit_localization", "my_summit_path_planning",
         "my_summit_navigation"]
# Python module -> rosdep key, for modules that are not ROS packages of the same name.
ROSDEP = {"numpy": "python3-numpy", "scipy": "python3-scipy", "cv2": "python3-opencv",
          "yaml": "python3-yaml", "psutil": "python3-psutil", "numba": "python3-numba",
          "PIL": "python3-pil", "pytest": "python3-pytest",
          # Debian ships diagnostic_updater's Python alone (no ROS package of that name)
          "diagnostic_updater": "python3-diagnostic-updater"}
# Modules that ship inside another ROS package.
PROVIDED_BY = {"rosgraph": "rosgraph", "roslaunch": "roslaunch", "rosunit": "rosunit",
               "genpy": "genpy", "rostest": "rostest"}
SKIP_DIRS = {"__pycache__"}


def python_files(pkg, part):
    root = os.path.join(SRC, pkg, part)
    out = []
    for folder, dirs, files in os.walk(root):
        dirs[:] = [d for d in dirs if d not in SKIP_DIRS]
        for name in files:
            path = os.path.join(folder, name)
            if name.endswith(".py") or (part in ("nodes", "scripts") and _is_python_script(path)):
                out.append(path)
    return out


def _is_python_script(path):
    with open(path, "rb") as f:
        first = f.readline()
    return first.startswith(b"#!") and b"python" in first


def top_level_imports(path):
    """Top-level module names imported anywhere in a Python file (absolute imports), but
    not the optional ones (inside ``try: ... except ImportError``)."""
    tree = ast.parse(open(path, encoding="utf-8").read(), filename=path)
    optional = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Try) and any(
                isinstance(h.type, ast.Name) and h.type.id in ("ImportError", "ModuleNotFoundError")
                for h in node.handlers):
            optional.update(id(n) for stmt in node.body for n in ast.walk(stmt))
    names = set()
    for node in ast.walk(tree):
        if id(node) in optional:
            continue
        if isinstance(node, ast.Import):
            names.update(a.name.split(".")[0] for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names.add(node.module.split(".")[0])
    return names


def local_modules(pkg):
    """Module names of the package's own test helpers and scripts (a script or a rostest
    node imports its siblings: its own folder is on sys.path when it runs)."""
    names = set()
    for part in ("test", "scripts", "nodes"):
        for path in glob.glob(os.path.join(SRC, pkg, part, "*")):
            names.add(os.path.splitext(os.path.basename(path))[0])
    return names


def launch_packages(pkg):
    """ROS packages a package's launch files start or include."""
    names = set()
    for path in glob.glob(os.path.join(SRC, pkg, "launch", "*.launch")):
        text = open(path).read()
        names.update(re.findall(r"\$\(find ([A-Za-z0-9_]+)\)", text))
        names.update(re.findall(r"<node[^>]*\bpkg=\"([A-Za-z0-9_]+)\"", text))
    names.discard(pkg)
    return names


def declared(pkg):
    root = ET.parse(os.path.join(SRC, pkg, "package.xml")).getroot()
    get = lambda *tags: {e.text.strip() for t in tags for e in root.findall(t)}
    return get("exec_depend", "depend"), get("test_depend", "depend") | get("exec_depend")


def dependency_of(module, pkg):
    """The package.xml key an import of module needs, or None (stdlib, the package itself,
    a sibling in its own test/, scripts/ or nodes/ folder). Helpers shared between
    packages live in a package's library (summit_nav_common.testing, ...): a module of
    another package's folders or of the workspace's tools/ is not importable by name."""
    if module in sys.stdlib_module_names or module == pkg or module in local_modules(pkg):
        return None
    if module in ROSDEP:
        return ROSDEP[module]
    return PROVIDED_BY.get(module, module)


def needed(pkg):
    """(runtime dependencies {key: first file}, test-only dependencies {key: first file})."""
    runtime, test = {}, {}
    for part, into in (("src", runtime), ("nodes", runtime), ("scripts", runtime), ("test", test)):
        for path in python_files(pkg, part):
            for module in top_level_imports(path):
                key = dependency_of(module, pkg)
                if key is not None:
                    into.setdefault(key, os.path.relpath(path, WS))
    for name in launch_packages(pkg):
        runtime.setdefault(name, f"src/{pkg}/launch")
    return runtime, test


@pytest.mark.parametrize("pkg", PACKAGES)
def test_package_xml_declares_what_the_package_uses(pkg):
    runtime, test = needed(pkg)
    exec_deps, test_deps = declared(pkg)
    missing = [f"exec_depend {k} (imported by {f})" for k, f in sorted(runtime.items()) if k not in exec_deps]
    missing += [f"test_depend {k} (imported by {f})" for k, f in sorted(test.items())
                if k not in test_deps and k not in exec_deps]
    assert not missing, f"src/{pkg}/package.xml lacks:\n  " + "\n  ".join(missing)


@pytest.mark.parametrize("pkg", PACKAGES)
def test_workspace_dependencies_are_used(pkg):
    """A workspace package declared as exec_depend is imported or started at run time."""
    runtime, _ = needed(pkg)
    exec_deps, _ = declared(pkg)
    unused = sorted(d for d in exec_deps if d in PACKAGES and d not in runtime)
    assert not unused, f"src/{pkg}/package.xml: exec_depend on {unused}, which nothing of it uses at run time"


@pytest.mark.parametrize("pkg", [p for p in PACKAGES if p != SIM])
def test_library_and_nodes_follow_the_chain(pkg):
    """A course package's library and nodes import only the packages below it in the
    chain, never the simulator (a robot runs them without it)."""
    allowed = set(CHAIN[:CHAIN.index(pkg)])
    bad = []
    for part in ("src", "nodes"):
        for path in python_files(pkg, part):
            for module in top_level_imports(path):
                if module in PACKAGES and module != pkg and module not in allowed:
                    bad.append(f"{os.path.relpath(path, WS)} imports {module}")
    assert not bad, "\n".join(bad)


def test_simulator_library_uses_only_the_base():
    bad = [f"{os.path.relpath(p, WS)} imports {m}" for part in ("src", "nodes")
           for p in python_files(SIM, part) for m in top_level_imports(p)
           if m in PACKAGES and m not in (SIM, BASE)]
    assert not bad, "\n".join(bad)


def test_every_package_is_in_the_chain_or_the_simulator():
    assert set(PACKAGES) == set(CHAIN) | {SIM}


@pytest.mark.parametrize("pkg", PACKAGES)
def test_each_launch_file_name_is_unique_in_its_package(pkg):
    """`roslaunch PKG NAME.launch` searches the whole package tree and refuses a name found
    twice ("multiple files named [move_base.launch] in package"). Vendors' move_base.launch
    files kept as test data inside my_summit_path_planning broke `roslaunch
    my_summit_path_planning move_base.launch` so (a fresh-clone CI run, 2026-11-27); such
    data lives in the workspace's data/ now."""
    names = {}
    for folder, dirs, files in os.walk(os.path.join(SRC, pkg)):
        for f in files:
            if f.endswith((".launch", ".test")):
                names.setdefault(f, []).append(os.path.relpath(os.path.join(folder, f), SRC))
    twice = {k: v for k, v in names.items() if len(v) > 1}
    assert not twice, f"launch file names found more than once in {pkg}: {twice}"
