"""What the amcl node loads at start."""
import ast
import os
import subprocess
import sys

NODE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "nodes", "amcl")


def test_amcl_loads_neither_opencv_nor_numba_nor_scipy():
    """amcl with its default likelihood field needs neither OpenCV nor numba: importing
    them cost the node ~160 MB of its 269 MB (the amcl row of the benchmark page,
    2026-11-27; the real amcl takes 26 MB). OpenCV came in through map_io's image reader
    and two distance transforms (now SciPy's, summit_nav_common.distance), numba through
    the beam model's ray caster (now imported at its first cast). Runs the node's
    own import statements in a fresh interpreter and lists the modules loaded. SciPy
    (~11 MB: the likelihood field's distance transform, the clusters' labelling) and
    Pillow (map_io's image reader; amcl gets its map as a message) went the same way in
    issue 43: 101 -> 85 MB on the tour."""
    tree = ast.parse(open(NODE).read())
    imports = [ast.unparse(n) for n in tree.body if isinstance(n, (ast.Import, ast.ImportFrom))]
    assert any("particle_filter" in i for i in imports)
    code = "\n".join(imports + ["import sys", "print(sorted(m for m in ('cv2', 'numba', 'scipy', 'PIL') if m in sys.modules))"])
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "[]"
