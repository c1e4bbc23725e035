"""The workspace's one grid line traversal against its one oracle, both tie rules."""
import numpy as np
import pytest

from summit_nav_common.line_cells import line_cells, line_cells_padded, line_cells_reference, rounded_steps


def ends(seed, n=400, span=40):
    rng = np.random.default_rng(seed)
    e = rng.integers(-span, span + 1, size=(n, 4))
    e[:20, 2:] = e[:20, :2]                       # single-cell lines
    e[20:40, 3] = e[20:40, 1] + (e[20:40, 2] - e[20:40, 0]) // 2 * 1   # many exact halves
    return e


@pytest.mark.parametrize("ties", ["away", "up"])
def test_line_cells_equal_the_oracle(ties):
    e = ends(1)
    line, x, y = line_cells(e[:, 0], e[:, 1], e[:, 2], e[:, 3], ties)
    for i, (x0, y0, x1, y1) in enumerate(e.tolist()):
        got = list(zip(x[line == i].tolist(), y[line == i].tolist()))
        assert got == line_cells_reference(x0, y0, x1, y1, ties)


@pytest.mark.parametrize("ties", ["away", "up"])
def test_padded_rows_equal_the_oracle(ties):
    e = ends(2).reshape(20, 20, 4)
    xs, ys, valid = line_cells_padded(e[..., 0], e[..., 1], e[..., 2], e[..., 3], ties)
    for idx in np.ndindex(20, 20):
        x0, y0, x1, y1 = e[idx].tolist()
        got = list(zip(xs[idx][valid[idx]].tolist(), ys[idx][valid[idx]].tolist()))
        assert got == line_cells_reference(x0, y0, x1, y1, ties)


def test_the_tie_rules_differ_only_at_halves_going_negative():
    assert line_cells_reference(0, 0, -4, -2, "away") == [(0, 0), (-1, -1), (-2, -1), (-3, -2), (-4, -2)]
    assert line_cells_reference(0, 0, -4, -2, "up") == [(0, 0), (-1, 0), (-2, -1), (-3, -1), (-4, -2)]
    assert line_cells_reference(0, 0, 4, 2, "away") == line_cells_reference(0, 0, 4, 2, "up")


def test_float_rounding_equals_integer_rounding_on_long_lines():
    rng = np.random.default_rng(3)
    n = rng.integers(1, 5000, 100000)
    d = rng.integers(-5000, 5001, 100000)
    k = rng.integers(0, 5001, 100000) % (n + 1)
    np.testing.assert_array_equal(rounded_steps(k, d, n, "up"), (2 * k * d + n) // (2 * n))
    np.testing.assert_array_equal(rounded_steps(k, d, n, "away"),
                                  np.sign(d) * ((2 * k * np.abs(d) + n) // (2 * n)))


def test_bad_tie_rule_is_named():
    with pytest.raises(ValueError, match="ties"):
        line_cells(0, 0, 3, 1, "down")
