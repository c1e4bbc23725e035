"""The workspace installs (`catkin_make install`) and the course's first step runs from
the install space alone: gmapping.launch with the simulator and the tour, its map autosaved
and judged against the simulator's true walls.

The install goes to a scratch build/devel/install of its own, so the workspace's devel
space is untouched; the launch runs in an environment with only the install space sourced
(no devel space, no source folder on any path).
"""
import os
import shlex
import subprocess
import time

import numpy as np
import pytest

from summit_nav_common.testing.roslaunch_session import free_port, run_bounded, stop_process_tree

WS = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

BUILD_TIMEOUT = 900      # [s] wall: cmake configure + install of every package
MAP_TIMEOUT = 240        # [s] wall until the first autosaved map
SPEED = 4.0              # simulated seconds per wall second
AUTOSAVE = 20.0          # [s] simulated, between autosaves
SPAWN = (2.0, 7.0)       # sim.launch's default spawn [m]: the map frame's origin in the world
MIN_WALL_CELLS = 300     # occupied cells in the first map (15 m of wall at 0.05 m)
MIN_PRECISION = 0.9      # share of them on a true wall (within one cell)
# Variables the devel space sets; the install space must stand without them.
WORKSPACE_VARS = ("ROS_PACKAGE_PATH", "PYTHONPATH", "CMAKE_PREFIX_PATH", "LD_LIBRARY_PATH",
                  "PKG_CONFIG_PATH", "ROSLISP_PACKAGE_DIRECTORIES")


def clean_env(tmp_path):
    env = {k: v for k, v in os.environ.items() if k not in WORKSPACE_VARS}
    env.update(ROS_LOG_DIR=str(tmp_path / "log"), ROS_HOME=str(tmp_path / "home"),
               PATH="/usr/bin:/bin:/usr/sbin:/sbin")
    return env


def in_install(install, command):
    """bash -c: source the install space's setup.bash, then command."""
    return ["bash", "-c", f"source {shlex.quote(str(install))}/setup.bash && {command}"]


@pytest.mark.integration
def test_mapping_step_runs_from_the_install_space(tmp_path):
    build, devel, install = tmp_path / "build", tmp_path / "devel", tmp_path / "install"
    env = clean_env(tmp_path)
    rc, out = run_bounded(
        ["catkin_make", "-C", WS, f"--build={build}", f"-DCATKIN_DEVEL_PREFIX={devel}",
         f"-DCMAKE_INSTALL_PREFIX={install}", "-DPYTHON_EXECUTABLE=/usr/bin/python3",
         "-DCATKIN_ENABLE_TESTING=OFF", "install"], env, BUILD_TIMEOUT)
    assert rc == 0, f"catkin_make install failed:\n{(out or '')[-5000:]}"

    # Every package, its Python modules and its nodes come from the install space.
    probe = ("for p in summit_nav_common summit_xl_sim my_summit_mapping my_summit_localization "
             "my_summit_path_planning my_summit_navigation; do rospack find $p; done; "
             "/usr/bin/python3 -c 'import summit_nav_common.ros.map_msgs, my_summit_mapping.rbpf, "
             "summit_xl_sim.world as w; print(w.__file__)'")
    rc, out = run_bounded(in_install(install, probe), env, 60)
    assert rc == 0, out
    lines = out.strip().splitlines()
    assert len(lines) == 7 and all(line.startswith(str(install)) for line in lines), out

    port = free_port()
    saved = tmp_path / "map"
    launch = (f"roslaunch -p {port} my_summit_mapping gmapping.launch speed:={SPEED} "
              f"autosave:={saved} autosave_interval:={AUTOSAVE}")
    proc = subprocess.Popen(in_install(install, launch), stdout=open(tmp_path / "launch.log", "w"),
                            stderr=subprocess.STDOUT, env=dict(env, ROS_MASTER_URI=f"http://127.0.0.1:{port}"),
                            start_new_session=True)
    try:
        end = time.monotonic() + MAP_TIMEOUT
        while not (saved.with_suffix(".yaml").exists() and saved.with_suffix(".pgm").exists()):
            assert proc.poll() is None, "the launch ended:\n" + (tmp_path / "launch.log").read_text()[-4000:]
            assert time.monotonic() < end, "no map saved:\n" + (tmp_path / "launch.log").read_text()[-4000:]
            time.sleep(0.5)
    finally:
        stop_process_tree(proc)

    from summit_nav_common.map_io import OCCUPIED, load_map
    from summit_xl_sim.world import World
    from scipy import ndimage
    grid = load_map(str(saved.with_suffix(".yaml")))
    world = World.from_yaml(os.path.join(WS, "src", "summit_xl_sim", "worlds", "course_building.yaml"))
    rows, cols = np.nonzero(grid.data == OCCUPIED)
    assert len(rows) >= MIN_WALL_CELLS, f"only {len(rows)} occupied cells in the saved map"
    x = grid.origin[0] + (cols + 0.5) * grid.resolution + SPAWN[0]
    y = grid.origin[1] + (rows + 0.5) * grid.resolution + SPAWN[1]
    gx, gy = world.to_grid(x, y)
    near_wall = ndimage.binary_dilation(world.walls, iterations=1)
    ix, iy = np.floor(gx).astype(int), np.floor(gy).astype(int)
    inside = (ix >= 0) & (iy >= 0) & (ix < near_wall.shape[1]) & (iy < near_wall.shape[0])
    precision = float(np.mean(inside & near_wall[np.clip(iy, 0, near_wall.shape[0] - 1),
                                                 np.clip(ix, 0, near_wall.shape[1] - 1)]))
    assert precision >= MIN_PRECISION, f"{precision:.3f} of the saved map's walls lie on true walls"
