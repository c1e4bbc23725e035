"""SlamConfig: gmapping's names and defaults, and from_dict's checks."""
import pytest

from my_summit_mapping.slam_config import SlamConfig


def test_defaults_are_gmappings():
    c = SlamConfig()
    assert (c.maxUrange, c.sigma, c.kernelSize, c.lstep, c.astep, c.iterations) == (80.0, 0.05, 1, 0.05, 0.05, 5)
    assert (c.lsigma, c.ogain, c.lskip, c.minimumScore) == (0.075, 3.0, 0, 0.0)
    assert (c.srr, c.srt, c.str, c.stt) == (0.1, 0.2, 0.1, 0.2)
    assert (c.linearUpdate, c.angularUpdate, c.temporalUpdate, c.resampleThreshold) == (1.0, 0.5, -1.0, 0.5)
    assert (c.particles, c.xmin, c.ymin, c.xmax, c.ymax, c.delta) == (30, -100.0, -100.0, 100.0, 100.0, 0.05)
    assert (c.llsamplerange, c.llsamplestep, c.lasamplerange, c.lasamplestep) == (0.01, 0.01, 0.005, 0.005)
    assert (c.occ_thresh, c.map_update_interval, c.maxRange) == (0.25, 5.0, None)


def test_from_dict_converts_and_round_trips():
    c = SlamConfig.from_dict({"particles": 100.0, "delta": 1, "maxRange": 30, "str": 0.05})
    assert c.particles == 100 and isinstance(c.particles, int)
    assert c.delta == 1.0 and isinstance(c.delta, float)
    assert c.maxRange == 30.0 and c.str == 0.05
    assert SlamConfig.from_dict(c.to_dict()) == c


@pytest.mark.parametrize("params, fragment", [
    ({"particle": 30}, "unknown gmapping parameter(s): particle"),
    ({"delta": 0.0}, "'delta'"),
    ({"sigma": -1.0}, "'sigma'"),
    ({"particles": 0}, "'particles'"),
    ({"particles": 2.5}, "'particles'"),
    ({"lskip": "1"}, "'lskip'"),
    ({"resampleThreshold": 1.5}, "'resampleThreshold'"),
    ({"maxUrange": float("nan")}, "'maxUrange'"),
    ({"xmin": 5.0, "xmax": 1.0}, "extent"),
    ({"srr": True}, "'srr'"),
])
def test_from_dict_rejects(params, fragment):
    with pytest.raises(ValueError) as err:
        SlamConfig.from_dict(params)
    assert fragment in str(err.value)
