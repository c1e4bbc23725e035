"""Point clouds (sensor_msgs/PointCloud2 and the older PointCloud) as numpy arrays.

Reference: sensor_msgs/PointCloud2's field layout (point_step, row_step, fields with
offset and datatype, is_bigendian) and sensor_msgs.point_cloud2.read_points, the
per-point Python reader kept as the test oracle. Here the x, y, z fields are read for
all points at once through a structured dtype over the message's bytes.
"""
import numpy as np

# sensor_msgs/PointField datatypes -> numpy scalar types
POINT_FIELD_TYPES = {1: "i1", 2: "u1", 3: "i2", 4: "u2", 5: "i4", 6: "u4", 7: "f4", 8: "f8"}


class CloudError(ValueError):
    """A point cloud message that cannot be read (missing field, sizes that do not add up)."""


def pointcloud2_xyz(msg):
    """(N, 3) float64 x, y, z of a sensor_msgs/PointCloud2, row by row (an organized cloud's
    rows one after the other); NaN points are kept (the caller drops them). CloudError
    naming what is wrong when x, y or z is missing or the data is shorter than its header
    says."""
    fields = {f.name: f for f in msg.fields}
    missing = [n for n in "xyz" if n not in fields]
    if missing:
        raise CloudError(f"PointCloud2 in frame '{msg.header.frame_id}' has no field {'/'.join(missing)}")
    order = ">" if msg.is_bigendian else "<"
    for n in "xyz":
        if fields[n].datatype not in POINT_FIELD_TYPES:
            raise CloudError(f"PointCloud2 field '{n}' has unknown datatype {fields[n].datatype}")
        end = fields[n].offset + np.dtype(POINT_FIELD_TYPES[fields[n].datatype]).itemsize
        if end > msg.point_step:
            raise CloudError(f"PointCloud2 in frame '{msg.header.frame_id}': field '{n}' ends at byte {end}, "
                             f"beyond point_step {msg.point_step}")
    if msg.height > 1 and msg.row_step < msg.width * msg.point_step:
        raise CloudError(f"PointCloud2 in frame '{msg.header.frame_id}': row_step {msg.row_step} is shorter "
                         f"than a row of {msg.width} points of {msg.point_step} bytes")
    dtype = np.dtype({"names": list("xyz"),
                      "formats": [order + POINT_FIELD_TYPES[fields[n].datatype] for n in "xyz"],
                      "offsets": [fields[n].offset for n in "xyz"],
                      "itemsize": msg.point_step})
    data = np.frombuffer(memoryview(msg.data), dtype=np.uint8)
    width, height = int(msg.width), int(msg.height)
    need = (height - 1) * msg.row_step + width * msg.point_step if width and height else 0
    if data.size < need:
        raise CloudError(f"PointCloud2 in frame '{msg.header.frame_id}': {data.size} bytes of data, "
                         f"its header needs {need} ({height} rows of {width} points)")
    if height == 0 or width == 0:
        return np.zeros((0, 3))
    row_bytes = width * msg.point_step
    if msg.row_step == row_bytes:
        pts = np.frombuffer(data[:height * row_bytes], dtype=dtype)
    else:   # rows padded to row_step: read each row's points
        pts = np.concatenate([np.frombuffer(data[r * msg.row_step:r * msg.row_step + row_bytes], dtype=dtype)
                              for r in range(height)])
    return np.column_stack([pts["x"], pts["y"], pts["z"]]).astype(np.float64)


def pointcloud_xyz(msg):
    """(N, 3) float64 of a sensor_msgs/PointCloud's points."""
    return np.array([(p.x, p.y, p.z) for p in msg.points], dtype=np.float64).reshape(-1, 3)
