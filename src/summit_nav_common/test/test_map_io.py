"""map_io: map_server's YAML semantics on its own reference case and made-up images."""
import math
import os

import cv2
import numpy as np
import pytest

from summit_nav_common.map_io import GridMap, MapError, image_to_grid, load_image_map, load_map, save_map

# The workspace's data/ folder (data/README.md names each source).
REF = os.path.join(os.path.dirname(__file__), "..", "..", "..", "data", "map_server_tests")
EXPECTED = np.array([
    0, 0, 0, 0, 0, 0, 0, 0, 0, 0,
    100, 100, 100, 100, 0, 0, 100, 100, 100, 0,
    100, 100, 100, 100, 0, 0, 100, 100, 100, 0,
    100, 0, 0, 0, 0, 0, 0, 0, 0, 0,
    100, 0, 0, 0, 0, 0, 0, 0, 0, 0,
    100, 0, 0, 0, 0, 0, 100, 100, 0, 0,
    100, 0, 0, 0, 0, 0, 100, 100, 0, 0,
    100, 0, 0, 0, 0, 0, 100, 100, 0, 0,
    100, 0, 0, 0, 0, 0, 100, 100, 0, 0,
    100, 0, 0, 0, 0, 0, 0, 0, 0, 0], np.int8)


def write_map(tmp_path, pixels, name="m", ext="pgm", **fields):
    cv2.imwrite(str(tmp_path / f"{name}.{ext}"), pixels)
    doc = {"image": f"{name}.{ext}", "resolution": 0.5, "origin": [1.0, 2.0, 0.0], "negate": 0,
           "occupied_thresh": 0.65, "free_thresh": 0.196}
    doc.update(fields)
    lines = [f"{k}: {v}" for k, v in doc.items() if v is not None]
    (tmp_path / f"{name}.yaml").write_text("\n".join(lines) + "\n")
    return str(tmp_path / f"{name}.yaml")


@pytest.mark.parametrize("image", ["testmap.png", "testmap.bmp"])
def test_reference_case(tmp_path, image):
    yaml_path = os.path.join(REF, "testmap.yaml")
    if image != "testmap.png":  # same YAML pointing at the BMP, in a temp folder
        text = open(yaml_path).read().replace("testmap.png", os.path.join(REF, image))
        yaml_path = str(tmp_path / "bmp.yaml")
        open(yaml_path, "w").write(text)
    m = load_map(yaml_path)
    assert (m.width, m.height, m.resolution) == (10, 10, 0.1)
    assert m.origin == (2.0, 3.0, 1.0)
    np.testing.assert_array_equal(m.data.ravel(), EXPECTED)


def test_missing_image_names_file(tmp_path):
    p = tmp_path / "m.yaml"
    p.write_text("image: nothere.pgm\nresolution: 0.1\norigin: [0,0,0]\nnegate: 0\n"
                 "occupied_thresh: 0.65\nfree_thresh: 0.196\n")
    with pytest.raises(MapError, match="nothere.pgm does not exist"):
        load_map(str(p))


@pytest.mark.parametrize("text, needle", [
    ("image: [unclosed\n", "malformed YAML"),
    ("just a string\n", "malformed map YAML"),
    ("resolution: 0.1\n", "no 'image' field"),
    ("image: m.pgm\nresolution: -1\norigin: [0,0,0]\nnegate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.1\n",
     "'resolution' must be > 0"),
    ("image: m.pgm\nresolution: 0.1\norigin: [0,0]\nnegate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.1\n",
     "'origin'"),
    ("image: m.pgm\nresolution: 0.1\norigin: [0,0,0]\nnegate: 0\noccupied_thresh: 1.5\nfree_thresh: 0.1\n",
     "'occupied_thresh' must be within"),
    ("image: m.pgm\nresolution: 0.1\norigin: [0,0,0]\nnegate: 0\noccupied_thresh: 0.3\nfree_thresh: 0.5\n",
     "'free_thresh' .* above"),
    ("image: m.pgm\nresolution: 0.1\norigin: [0,0,0]\nnegate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.1\n"
     "mode: fancy\n", "'mode' must be one of"),
    ("image: m.pgm\nresolution: 0.1\norigin: [0,0,0]\noccupied_thresh: 0.65\nfree_thresh: 0.1\n",
     "no 'negate' field"),
])
def test_bad_yaml_names_field(tmp_path, text, needle):
    cv2.imwrite(str(tmp_path / "m.pgm"), np.full((4, 4), 254, np.uint8))
    p = tmp_path / "m.yaml"
    p.write_text(text)
    with pytest.raises(MapError, match=needle) as e:
        load_map(str(p))
    assert str(p) in str(e.value)


def test_negate_scale_raw(tmp_path):
    # One row of grey levels, top row of the image = highest y.
    img = np.array([[0, 50, 100, 150, 200, 254]], np.uint8)
    trin = load_map(write_map(tmp_path, img)).data[0]
    # occ = (255 - v)/255: 1.0, .80, .61, .41, .22, .004
    np.testing.assert_array_equal(trin, [100, 100, -1, -1, -1, 0])
    neg = load_map(write_map(tmp_path, img, name="n", negate=1)).data[0]
    np.testing.assert_array_equal(neg, [0, -1, -1, -1, 100, 100])
    scale = load_map(write_map(tmp_path, img, name="s", mode="scale")).data[0]
    expected_mid = [int(1 + 98 * (((255 - v) / 255) - 0.196) / (0.65 - 0.196)) for v in (100, 150, 200)]
    np.testing.assert_array_equal(scale, [100, 100] + expected_mid + [0])
    raw = load_map(write_map(tmp_path, img, name="r", mode="raw")).data[0]
    np.testing.assert_array_equal(raw.view(np.uint8), [0, 50, 100, 150, 200, 254])


def test_rows_flipped_and_alpha(tmp_path):
    img = np.full((2, 3), 254, np.uint8)
    img[0, 0] = 0  # top-left pixel -> highest row, first column
    m = load_map(write_map(tmp_path, img))
    assert m.data[1, 0] == 100 and m.data[0, 0] == 0
    # A transparent pixel in scale mode is unknown, as map_server does.
    rgba = np.zeros((1, 2, 4), np.uint8)
    rgba[0, :, :3] = 120
    rgba[0, 0, 3] = 255
    grid = image_to_grid(rgba, 0, 0.65, 0.196, "scale")
    assert grid[0, 0] > 0 and grid[0, 1] == -1



def yaml_for(tmp_path, image, mode="trinary", negate=0):
    path = tmp_path / f"{image}.{mode}.{negate}.yaml"
    path.write_text(f"image: {image}\nresolution: 0.1\norigin: [0, 0, 0]\nnegate: {negate}\n"
                    f"occupied_thresh: 0.65\nfree_thresh: 0.196\nmode: {mode}\n")
    return str(path)


def test_image_formats_as_the_real_map_server_reads_them(tmp_path):
    """What SDL_image hands the real map_server, checked against it (noetic, 84 cases of
    compare_map_server.py, 2026-11-27): before, ours (OpenCV) differed on 28 of them. A
    palette image is read as its palette indices, not colours; a 16-bit image as the high
    byte; scale mode takes the last byte of an RGB pixel (blue; red in a BMP) as alpha;
    grey with alpha counts as four bytes (grey three times, then alpha)."""
    from PIL import Image
    # Palette: index 1 is black, index 0 white; raw mode gives the indices.
    pal = Image.new("P", (3, 1))
    pal.putpalette([255, 255, 255, 0, 0, 0] + [0] * 762)
    pal.putdata([0, 1, 1])
    for ext in ("png", "bmp"):
        pal.save(tmp_path / f"pal.{ext}")
        raw = load_map(yaml_for(tmp_path, f"pal.{ext}", "raw")).data[0]
        np.testing.assert_array_equal(raw, [0, 1, 1])
    # 16-bit grey: the high byte (0x12AB -> 0x12 = 18).
    Image.fromarray(np.array([[0x12AB, 0xFFFF]], np.uint16), "I;16").save(tmp_path / "g16.png")
    np.testing.assert_array_equal(load_map(yaml_for(tmp_path, "g16.png", "raw")).data[0].view(np.uint8), [18, 255])
    # Scale mode, RGB (200, 200, 0): mean 133.3, occ 0.48, between the thresholds; the
    # last byte 0 reads as transparent -> unknown. In a BMP the bytes are B, G, R, so
    # (0, 200, 200) is the one read as transparent.
    rgb = np.array([[[200, 200, 0], [0, 200, 200]]], np.uint8)
    for ext, unknown in (("png", 0), ("bmp", 1)):
        Image.fromarray(rgb, "RGB").save(tmp_path / f"rgb.{ext}")
        scale = load_map(yaml_for(tmp_path, f"rgb.{ext}", "scale")).data[0]
        assert scale[unknown] == -1 and scale[1 - unknown] == int(1 + 98 * ((255 - 400 / 3) / 255 - 0.196)
                                                                 / (0.65 - 0.196))
    # Grey 254 with alpha 100, trinary: (3 x 254 + 100) / 4 = 215.5, occ 0.155 -> free
    # (as two bytes the mean would be 177, occ 0.31 -> unknown).
    Image.fromarray(np.array([[[254, 100]]], np.uint8), "LA").save(tmp_path / "la.png")
    assert load_map(yaml_for(tmp_path, "la.png")).data[0, 0] == 0


def test_file_that_is_not_an_image_names_it(tmp_path):
    (tmp_path / "m.png").write_text("not an image")
    with pytest.raises(MapError, match=r"field 'image': cannot read .*m\.png as an image"):
        load_map(yaml_for(tmp_path, "m.png"))
    from PIL import Image
    Image.fromarray(np.zeros((2, 2), np.float32), "F").save(tmp_path / "f.tiff")
    with pytest.raises(MapError, match="F pixels; map_server reads 8- and 16-bit grey"):
        load_map(yaml_for(tmp_path, "f.tiff"))

def test_save_then_load_round_trip(tmp_path):
    data = np.array([[0, 100, -1], [50, 10, 90]], np.int8)
    grid = GridMap(data=data, resolution=0.05, origin=(-1.5, 2.25, 0.0))
    pgm, yml = save_map(grid, str(tmp_path / "saved"))
    back = load_map(yml)
    # map_saver: <= 25 free, >= 65 occupied, else unknown
    np.testing.assert_array_equal(back.data, [[0, 100, -1], [-1, 0, 100]])
    assert back.resolution == pytest.approx(0.05)
    assert back.origin == pytest.approx((-1.5, 2.25, 0.0))
    assert open(pgm, "rb").read().startswith(b"P5\n")
    umask = os.umask(0)
    os.umask(umask)
    assert os.stat(pgm).st_mode & 0o777 == 0o666 & ~umask  # not mkstemp's 0600


def test_save_into_missing_folder_keeps_nothing_broken(tmp_path):
    grid = GridMap(data=np.zeros((2, 2), np.int8), resolution=0.1)
    with pytest.raises(MapError, match="does not exist"):
        save_map(grid, str(tmp_path / "nope" / "map"))


def test_failed_save_keeps_previous_map(tmp_path):
    good = GridMap(data=np.zeros((2, 2), np.int8), resolution=0.1)
    save_map(good, str(tmp_path / "map"))
    before = (tmp_path / "map.pgm").read_bytes(), (tmp_path / "map.yaml").read_bytes()
    os.chmod(tmp_path, 0o500)
    try:
        if os.access(tmp_path, os.W_OK):  # root ignores the mode: simulate with a bad grid
            with pytest.raises(Exception):
                save_map(GridMap(data=None, resolution=0.1), str(tmp_path / "map"))
        else:
            with pytest.raises(MapError, match="not writable"):
                save_map(good, str(tmp_path / "map"))
    finally:
        os.chmod(tmp_path, 0o700)
    assert ((tmp_path / "map.pgm").read_bytes(), (tmp_path / "map.yaml").read_bytes()) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["map.pgm", "map.yaml"]


def test_unknown_solid_beyond_field_is_read(tmp_path):
    """unknown_solid_beyond (the simulator's own map field, a distance [m]) is read into
    the map's source facts; what it does is the simulator's (its test_world_and_tour)."""
    img = np.full((8, 40), 254, np.uint8)
    assert load_map(write_map(tmp_path, img, name="d")).source["unknown_solid_beyond"] is None
    assert load_map(write_map(tmp_path, img, name="c", unknown_solid_beyond=1.2)).source[
        "unknown_solid_beyond"] == pytest.approx(1.2)
    for bad in ("maybe", -1, "true"):
        with pytest.raises(MapError, match="'unknown_solid_beyond' must be a distance >= 0"):
            load_map(write_map(tmp_path, img, name="e", unknown_solid_beyond=bad))


def test_image_with_resolution_as_deprecated_map_server():
    """``map_server testmap.png 0.1``: the reference grid, at origin 0, trinary."""
    grid = load_image_map(os.path.join(REF, "testmap.png"), 0.1)
    np.testing.assert_array_equal(grid.data.reshape(-1), EXPECTED)
    assert grid.resolution == 0.1 and grid.origin == (0.0, 0.0, 0.0)
    assert (grid.source["mode"], grid.source["negate"], grid.source["occupied_thresh"],
            grid.source["free_thresh"]) == ("trinary", 0, 0.65, 0.196)
    # Same cells as the YAML form of the same picture.
    np.testing.assert_array_equal(grid.data, load_map(os.path.join(REF, "testmap.yaml")).data)
    negated = load_image_map(os.path.join(REF, "testmap.bmp"), 0.25, negate=1)
    assert negated.resolution == 0.25
    np.testing.assert_array_equal(negated.data.reshape(-1) == 100, EXPECTED == 0)


@pytest.mark.parametrize("args, needle", [
    (("gone.png", 0.1), "gone.png: image file does not exist"),
    (("testmap.png", 0.0), "resolution must be a positive number [m/cell], got 0.0"),
    (("testmap.png", -1), "resolution must be a positive number [m/cell], got -1"),
    (("testmap.png", float("nan")), "resolution must be a positive number"),
    (("testmap.png", "0.1"), "resolution must be a positive number [m/cell], got '0.1'"),
    (("testmap.png", 0.1, 2), "negate must be 0 or 1, got 2"),
    (("testmap.png", 0.1, 0, 0.2, 0.5), "free_thresh (0.5) is above occupied_thresh (0.2)"),
])
def test_image_with_resolution_bad_input_names_it(args, needle):
    image, *rest = args
    with pytest.raises(MapError) as e:
        load_image_map(os.path.join(REF, image), *rest)
    assert needle in str(e.value)
