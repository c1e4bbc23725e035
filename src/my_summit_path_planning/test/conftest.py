"""Shared fixtures: small in-memory grids and the Summit XL footprint (no ROS master)."""
import numpy as np
import pytest

from my_summit_path_planning.costmap import Costmap2D, Footprint, LayeredCostmap
from my_summit_path_planning import cost_values as cv

SUMMIT_FOOTPRINT = [[0.36, 0.31], [-0.36, 0.31], [-0.36, -0.31], [0.36, -0.31]]


@pytest.fixture
def footprint():
    """The Summit XL footprint, unpadded."""
    return Footprint.from_params(SUMMIT_FOOTPRINT)


class CostmapHandle:
    """A costmap handle as move_base's CostmapROS gives the recoveries: layered, lock,
    get_robot_pose() (a fixed pose, settable), name."""

    def __init__(self, layered, pose, name="costmap"):
        import threading
        self.layered, self.lock, self.pose, self.name = layered, threading.RLock(), pose, name

    def get_robot_pose(self):
        return self.pose


@pytest.fixture
def costmap_handle():
    """The CostmapHandle class (pytest's importlib mode cannot import conftest)."""
    return CostmapHandle


@pytest.fixture
def make_static_costmap():
    """The static_costmap builder (pytest's importlib mode cannot import conftest)."""
    return static_costmap


def static_costmap(occ, footprint, resolution=0.05, origin=(0.0, 0.0, 0.0), inflation=None,
                   track_unknown=True):
    """A global-style LayeredCostmap (static + inflation) over an int8 OccupancyGrid array."""
    plugins = [{"name": "static_layer", "type": "costmap_2d::StaticLayer"},
               {"name": "inflation_layer", "type": "costmap_2d::InflationLayer"}]
    params = {"static_layer": {"track_unknown_space": track_unknown},
              "inflation_layer": inflation or {"inflation_radius": 0.55, "cost_scaling_factor": 10.0}}
    default = cv.NO_INFORMATION if track_unknown else cv.FREE_SPACE
    lc = LayeredCostmap.from_plugins(plugins, params, Costmap2D(1, 1, resolution, 0, 0, default), footprint)
    lc.layer("static_layer").set_map(np.asarray(occ, np.int8), resolution, origin)
    lc.update_map(0.0, 0.0, 0.0)
    return lc


class TwoGaps:
    """40 x 21 cells at 0.1 m: a 5-cell-thick wall across x 1.8-2.3 m with a direct gap of
    cost 40 (rows 9..11, on the straight line y 1.05 m) and a free detour gap (rows 16..18)."""

    @staticmethod
    def costmap():
        cm = Costmap2D(40, 21, 0.1)
        cm.data[:, 18:23] = cv.LETHAL_OBSTACLE
        cm.data[9:12, 18:23] = 40
        cm.data[16:19, 18:23] = cv.FREE_SPACE
        return cm

    @staticmethod
    def through_direct_gap(result):
        """True when the plan crosses the wall through the direct gap."""
        at_wall = np.abs(result.path[:, 0] - 2.05) < 0.25
        return bool((result.path[at_wall, 1] < 1.25).all())


@pytest.fixture
def two_gaps():
    """TwoGaps (a fixture: pytest's importlib mode cannot import conftest)."""
    return TwoGaps
