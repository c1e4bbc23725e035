"""pointcloud2_xyz against sensor_msgs.point_cloud2.read_points, the per-point reader."""
import struct

import numpy as np
import pytest
import sensor_msgs.point_cloud2 as pc2
from sensor_msgs.msg import PointCloud, PointCloud2, PointField
from geometry_msgs.msg import Point32
from std_msgs.msg import Header

from summit_nav_common.ros.clouds import CloudError, pointcloud2_xyz, pointcloud_xyz

FIELDS = [PointField("intensity", 0, PointField.FLOAT32, 1), PointField("x", 4, PointField.FLOAT32, 1),
          PointField("y", 8, PointField.FLOAT32, 1), PointField("z", 12, PointField.FLOAT32, 1),
          PointField("ring", 16, PointField.UINT16, 1)]


def cloud(points, fields=FIELDS):
    return pc2.create_cloud(Header(frame_id="camera"), fields, points)


def oracle(msg):
    return np.array([p[:3] for p in pc2.read_points(msg, field_names=("x", "y", "z"))], dtype=np.float64)


def test_fields_in_any_order_with_others_between():
    rng = np.random.default_rng(3)
    pts = [(float(i), *rng.normal(size=3), 7) for i in range(50)]
    pts[5] = (0.0, float("nan"), 1.0, 2.0, 0)      # NaN points are kept, for the caller to drop
    msg = cloud(pts)
    got, want = pointcloud2_xyz(msg), oracle(msg)
    assert got.shape == (50, 3)
    np.testing.assert_array_equal(np.isnan(got), np.isnan(want))
    np.testing.assert_allclose(got[~np.isnan(got)], want[~np.isnan(want)])


def test_organized_cloud_with_padded_rows_and_float64_big_endian():
    """Two rows of three points, each row padded by 4 bytes; x, y, z as big-endian doubles."""
    fields = [PointField("x", 0, PointField.FLOAT64, 1), PointField("y", 8, PointField.FLOAT64, 1),
              PointField("z", 16, PointField.FLOAT64, 1)]
    pts = np.arange(18, dtype=np.float64).reshape(6, 3)
    rows = [b"".join(struct.pack(">ddd", *p) for p in pts[r * 3:r * 3 + 3]) + b"\0" * 4 for r in range(2)]
    msg = PointCloud2(header=Header(frame_id="c"), height=2, width=3, fields=fields, is_bigendian=True,
                      point_step=24, row_step=76, data=b"".join(rows), is_dense=True)
    np.testing.assert_array_equal(pointcloud2_xyz(msg), pts)
    as_numpy = PointCloud2(**{k: getattr(msg, k) for k in msg.__slots__})
    as_numpy.data = np.frombuffer(msg.data, dtype=np.uint8)      # what numpy_msg gives the node
    np.testing.assert_array_equal(pointcloud2_xyz(as_numpy), pts)


def test_bad_clouds_are_named():
    with pytest.raises(CloudError, match="no field z"):
        pointcloud2_xyz(cloud([(1.0, 2.0)], [PointField("x", 0, 7, 1), PointField("y", 4, 7, 1)]))
    msg = cloud([(0.0, 1.0, 2.0, 3.0, 1)] * 4)
    msg.data = msg.data[:-5]
    with pytest.raises(CloudError, match="bytes of data, its header needs 72"):
        pointcloud2_xyz(msg)
    assert pointcloud2_xyz(cloud([])).shape == (0, 3)
    msg = cloud([(0.0, 1.0, 2.0, 3.0, 1)] * 4)
    msg.point_step = 12                             # z (offset 12) would lie past each point
    with pytest.raises(CloudError, match="field 'y' ends at byte 12, beyond point_step 12|field 'z'"):
        pointcloud2_xyz(msg)
    msg = cloud([(0.0, 1.0, 2.0, 3.0, 1)] * 4)
    msg.height, msg.width, msg.row_step = 2, 2, 20  # rows would overlap
    with pytest.raises(CloudError, match="row_step 20 is shorter than a row of 2 points"):
        pointcloud2_xyz(msg)


def test_old_pointcloud():
    msg = PointCloud(header=Header(frame_id="c"), points=[Point32(1, 2, 3), Point32(4, 5, 6)])
    np.testing.assert_array_equal(pointcloud_xyz(msg), [[1, 2, 3], [4, 5, 6]])
    assert pointcloud_xyz(PointCloud()).shape == (0, 3)
