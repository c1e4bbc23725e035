"""The map of the multi_robot_crossing rostest (test/data/crossing_hall.yaml): the 3 m
wide hall of willow-full east of the lesson's room, cut out of the map, with the walls
that make its doorway drawn in.

Drawn in the map, the walls are known to both robots' global costmaps from the start (the
static layer), as to the simulator (the map is its world). As boxes put into the
simulator they were known to a costmap only where that robot's laser had seen them, and
a robot's first look misses some: see multi_robot_crossing.test.

Run as a script to write the map again from maps/willow-full.yaml:
    python3 src/my_summit_navigation/test/test_crossing_map.py
The tests check that the committed map is what this file makes, and that the doorway is
the only way between the hall's two halves for a robot in the simulator, where unknown
cells are open space.
"""
import os

import numpy as np

from summit_nav_common.files import write_atomic
from summit_nav_common.grid_kernels import components8
from summit_nav_common.map_io import FREE, OCCUPIED, UNKNOWN, GridMap, grid_to_pgm, load_map

HERE = os.path.dirname(os.path.abspath(__file__))
WILLOW = os.path.join(HERE, "..", "maps", "willow-full.yaml")
MAP = os.path.join(HERE, "data", "crossing_hall")   # .pgm, .yaml

# [m] map frame, on willow-full's 0.1 m cell edges: x0, x1, y0, y1
CROP = (14.8, 19.6, 12.8, 22.3)
WALLS = {
    # across the hall, from its west edge to the doorway (the unknown cells west of the
    # hall's wall are open space in the simulator: the wall closes them too)
    "door_west": (14.8, 17.9, 15.4, 15.7),
    # along the arc wall of the big hall, whose dashed cells let a robot through
    "arc": (19.3, 19.6, 12.8, 20.3),
    # the hall's south end: its way to the south corridor
    "close_south": (14.8, 19.6, 12.8, 13.1),
}
DOORWAY = (17.9, 19.3, 15.4, 15.7)
SOUTH_START, NORTH_START = (18.43, 14.03), (18.52, 18.53)   # robot_0's, robot_1's [m]
YAML = """# The multi_robot_crossing rostest's world and map: willow-full.pgm cut to x {x0}..{x1},
# y {y0}..{y1} m (same map frame), its outermost cells walls (as the simulator makes them),
# with the doorway's walls drawn in. Made by test/test_crossing_map.py (run it to write
# this map again); the .test says why.
image: crossing_hall.pgm
resolution: {res}
origin: [{x0}, {y0}, 0.0]
negate: 0
occupied_thresh: 0.65
free_thresh: 0.196
"""


def _cells(grid, x0, x1, y0, y1):
    """(row slice, col slice) of the cells of grid inside [x0, x1] x [y0, y1] [m] (cell edges)."""
    res, (ox, oy, _) = grid.resolution, grid.origin
    cols = slice(int(round((x0 - ox) / res)), int(round((x1 - ox) / res)))
    rows = slice(int(round((y0 - oy) / res)), int(round((y1 - oy) / res)))
    return rows, cols


def crossing_map(willow):
    """The crossing's GridMap from willow-full's (a GridMap with its origin at (0, 0, 0))."""
    rows, cols = _cells(willow, *CROP)
    data = willow.data[rows, cols].copy()
    data[[0, -1], :] = OCCUPIED
    data[:, [0, -1]] = OCCUPIED
    grid = GridMap(data=data, resolution=willow.resolution, origin=(CROP[0], CROP[2], 0.0))
    for x0, x1, y0, y1 in WALLS.values():
        grid.data[_cells(grid, x0, x1, y0, y1)] = OCCUPIED
    return grid


def _open_components(data):
    """8-connected components of the cells a robot may cross in the simulator (free or
    unknown; its outermost cells are walls there). 8-connected: more connected than a robot
    can drive, so cells in different components are surely apart."""
    open_space = (data == FREE) | (data == UNKNOWN)
    open_space[[0, -1], :] = False
    open_space[:, [0, -1]] = False
    return components8(open_space.astype(np.uint8))


def test_committed_map_is_the_one_made_here():
    made = crossing_map(load_map(WILLOW))
    committed = load_map(MAP + ".yaml")
    assert committed.origin == made.origin and committed.resolution == made.resolution
    np.testing.assert_array_equal(committed.data, made.data)


def test_the_doorway_is_the_only_way_between_the_halves():
    grid = load_map(MAP + ".yaml")
    south, north = grid.world_to_cell(*SOUTH_START), grid.world_to_cell(*NORTH_START)
    labels = _open_components(grid.data)
    assert labels[south[1], south[0]] > 0 and labels[north[1], north[0]] > 0, "a start is in a wall"
    assert labels[south[1], south[0]] == labels[north[1], north[0]], "the doorway does not join the halves"
    closed = grid.data.copy()
    closed[_cells(grid, *DOORWAY)] = OCCUPIED
    labels = _open_components(closed)
    assert labels[south[1], south[0]] != labels[north[1], north[0]], \
        "with the doorway closed the halves are still joined: another way between them"


def main():
    grid = crossing_map(load_map(WILLOW))
    img = grid_to_pgm(grid.data)
    header = f"P5\n{img.shape[1]} {img.shape[0]}\n255\n".encode()
    write_atomic(MAP + ".pgm", header + img.tobytes())
    x0, x1, y0, y1 = CROP
    write_atomic(MAP + ".yaml", YAML.format(x0=x0, x1=x1, y0=y0, y1=y1, res=grid.resolution))
    print(f"wrote {MAP}.pgm ({grid.width} x {grid.height} cells) and {MAP}.yaml")


if __name__ == "__main__":
    main()
