"""summit_nav_common.testing.scenes: the synthetic worlds other packages' tests build on."""
import math

import numpy as np

from summit_nav_common.map_io import OCCUPIED
from summit_nav_common.testing import scenes


def test_ray_cast_is_exact_to_the_room_walls_and_the_pillar():
    ranges = scenes.ray_cast((0.0, 0.0, 0.0), angles=np.array([0.0, math.pi / 2, -math.pi / 2]))
    np.testing.assert_allclose(ranges, [5.0, 4.0, 4.0])
    # towards the pillar's lower-left corner region: its face x = 1.8 at y 1.5
    r = scenes.ray_cast((0.0, 1.5, 0.0), angles=np.array([0.0]))
    np.testing.assert_allclose(r, [1.8])


def test_ray_cast_reports_inf_beyond_max_range():
    r = scenes.ray_cast((0.0, 0.0, 0.0), angles=np.array([0.0]), max_range=3.0)
    assert np.isinf(r[0])


def test_square_room_has_walls_on_its_border_only():
    room = scenes.square_room(2.0, 0.1)
    assert room.data.shape == (20, 20) and room.resolution == 0.1
    border = np.ones((20, 20), bool)
    border[1:-1, 1:-1] = False
    assert (room.data[border] == OCCUPIED).all() and (room.data[~border] == 0).all()


def test_known_corridor_is_known_up_to_column_30():
    g = scenes.known_corridor()
    assert (g[5:15, :30] == 0).all() and (g[:, 30:] == -1).all()
    assert (g[[4, 15], :30] == 100).all()
