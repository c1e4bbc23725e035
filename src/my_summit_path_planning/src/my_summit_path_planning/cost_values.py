"""Cost values of a costmap cell and their translation to nav_msgs/OccupancyGrid.

Reference: costmap_2d ``cost_values.h`` (the four special values) and
``costmap_2d_publisher.cpp`` (the translation table used when a costmap is published as
an OccupancyGrid). One place for these constants, as in costmap_2d.
"""
import numpy as np

NO_INFORMATION = 255               # unknown space
LETHAL_OBSTACLE = 254              # an obstacle in the cell
INSCRIBED_INFLATED_OBSTACLE = 253  # the robot centre here puts an obstacle inside its footprint
MAX_NON_OBSTACLE = 252             # the highest cost a robot centre may legally have
FREE_SPACE = 0

# OccupancyGrid values for published costmaps.
OCC_UNKNOWN = -1
OCC_LETHAL = 100
OCC_INSCRIBED = 99
# costmap_2d maps the ordinary costs 1..252 linearly onto 1..98 (integer arithmetic).
OCC_MAX_ORDINARY = 98


def _build_translation_table():
    table = np.zeros(256, dtype=np.int8)
    ordinary = np.arange(1, INSCRIBED_INFLATED_OBSTACLE)
    table[1:INSCRIBED_INFLATED_OBSTACLE] = 1 + (97 * (ordinary - 1)) // 251
    table[FREE_SPACE] = 0
    table[INSCRIBED_INFLATED_OBSTACLE] = OCC_INSCRIBED
    table[LETHAL_OBSTACLE] = OCC_LETHAL
    table[NO_INFORMATION] = OCC_UNKNOWN
    table.setflags(write=False)
    return table


# cost (0..255) -> OccupancyGrid value (-1..100), costmap_2d's cost_translation_table_.
COST_TRANSLATION_TABLE = _build_translation_table()


def costs_to_occupancy(costs):
    """uint8 costmap array (any shape) -> int8 OccupancyGrid values of the same shape.

    0 -> 0, 1..252 -> 1..98, 253 (inscribed) -> 99, 254 (lethal) -> 100, 255 -> -1.
    """
    costs = np.asarray(costs)
    if costs.dtype != np.uint8:
        raise TypeError(f"costs must be uint8 costmap values, got {costs.dtype}")
    return COST_TRANSLATION_TABLE[costs]
