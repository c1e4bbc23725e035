"""OccupancyGrid <-> GridMap conversions used by map_server, map_saver and slam_gmapping;
saver -> server round trip through map_io."""
import math

import numpy as np
import pytest
from nav_msgs.msg import OccupancyGrid
from numpy.testing import assert_allclose, assert_array_equal
from rospy.numpy_msg import numpy_msg
from summit_nav_common.map_io import GridMap, load_map, save_map

from summit_nav_common.ros import map_msgs


def _grid():
    data = np.full((4, 6), -1, np.int8)
    data[0, :] = 0
    data[1, 2] = 100
    data[3, 5] = 100   # top-right cell: row 3 is the highest y
    return GridMap(data=data, resolution=0.05, origin=(-1.5, 2.25, 0.3))


@pytest.mark.parametrize("msg_class", [OccupancyGrid, numpy_msg(OccupancyGrid)])
def test_grid_to_msg_layout(msg_class):
    msg = map_msgs.grid_to_msg(_grid(), "map", msg_class=msg_class)
    assert msg.header.frame_id == "map"
    assert (msg.info.width, msg.info.height) == (6, 4)
    assert msg.info.resolution == pytest.approx(0.05)
    # row-major from the lower-left cell: cell (col 2, row 1) is index 1*6+2
    data = np.asarray(msg.data)
    assert data[1 * 6 + 2] == 100 and data[3 * 6 + 5] == 100 and data[0] == 0 and data[6] == -1
    o = msg.info.origin
    assert (o.position.x, o.position.y) == pytest.approx((-1.5, 2.25))
    assert map_msgs.quaternion_to_yaw(o.orientation) == pytest.approx(0.3)
    assert o.orientation.z ** 2 + o.orientation.w ** 2 == pytest.approx(1.0)


def test_serialized_numpy_and_plain_messages_are_identical():
    import io
    buffers = []
    for cls in (OccupancyGrid, numpy_msg(OccupancyGrid)):
        buf = io.BytesIO()
        msg = map_msgs.grid_to_msg(_grid(), "map", msg_class=cls)
        (msg.serialize_numpy(buf, np) if cls is not OccupancyGrid else msg.serialize(buf))
        buffers.append(buf.getvalue())
    assert buffers[0] == buffers[1]


def test_msg_round_trip_and_size_check():
    grid = _grid()
    back = map_msgs.msg_to_grid(map_msgs.grid_to_msg(grid, "map"))
    assert_array_equal(back.data, grid.data)
    assert_allclose(back.origin, grid.origin, atol=1e-12)
    bad = map_msgs.grid_to_msg(grid, "map")
    bad.info.width = 7
    with pytest.raises(ValueError, match="28 cells|24 cells"):
        map_msgs.msg_to_grid(bad)


def test_saver_to_server_round_trip(tmp_path):
    """What map_saver writes (trinary PGM + YAML) map_server loads back cell for cell."""
    grid = _grid()
    grid.data[2, 1] = 30   # between free (<= 25) and occupied (>= 65): unknown in the file
    grid.data[2, 3] = 70   # >= 65: occupied
    save_map(map_msgs.msg_to_grid(map_msgs.grid_to_msg(grid, "map")), str(tmp_path / "m"))
    loaded = load_map(str(tmp_path / "m.yaml"))
    expected = grid.data.copy()
    expected[2, 1] = -1
    expected[2, 3] = 100
    assert_array_equal(loaded.data, expected)
    assert_allclose(loaded.origin, (-1.5, 2.25, 0.3), atol=1e-6)
    assert loaded.resolution == pytest.approx(0.05)


def test_yaw_quaternion_round_trip():
    from geometry_msgs.msg import Quaternion
    for yaw in np.linspace(-math.pi + 1e-6, math.pi - 1e-6, 9):
        z, w = map_msgs.yaw_to_quaternion_zw(yaw)
        assert map_msgs.quaternion_to_yaw(Quaternion(0, 0, z, w)) == pytest.approx(yaw)
