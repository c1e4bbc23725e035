"""The simulator's /diagnostics checks (summit_xl_sim.diagnostics) and the achieved speed
(Pacer.factor) on a fake wall clock.

The checks these replace were diagnostic_updater FrequencyStatus tasks ticked from the
simulation loop at each laser and odometry tick and read on the simulator's own clock: the
rate they measured was the configured one by construction, however slowly the machine
ran, and the scan's ticked even when no scan was cast. These tests run the pure checks on
a simulator that falls behind and on a laser nobody listens to.
"""
import pytest

from summit_nav_common.diagnostic_checks import OK, WARN, RateMeter
from summit_xl_sim.diagnostics import pace_check, published_rate_check
from summit_xl_sim.pace import Pacer

DT = 0.005   # [s] simulated step


class FakeClock:
    def __init__(self):
        self.t = 100.0

    def __call__(self):
        return self.t


def run(pacer, clock, steps, cost, start=0, report_every=200):
    """Steps the loop from step `start` for `steps` steps of DT, each costing `cost` wall
    seconds, reading pacer.factor once per report_every steps (1 s simulated); returns
    the factors read."""
    factors = []
    for n in range(start + 1, start + steps + 1):
        clock.t += cost
        clock.t += pacer.delay(n * DT)
        if n % report_every == 0:
            factors.append(pacer.factor(n * DT))
    return factors


def test_factor_is_the_asked_speed_on_a_machine_that_keeps_up():
    clock = FakeClock()
    pacer = Pacer(4.0, now=clock)
    factors = run(pacer, clock, 4000, cost=0.0003)
    assert pacer.factor(0.0 + 4000 * DT) == pytest.approx(4.0, rel=0.01)
    assert all(f == pytest.approx(4.0, rel=0.01) for f in factors)
    assert pace_check(factors[-1], 4.0).level == OK


def test_factor_and_check_follow_a_slowdown_within_one_window():
    """4x asked; after 20 s simulated each 5 ms step costs 2.5 ms of wall time (2x at
    best): the factor drops to 2 within a window (5 s wall) and the check says so naming
    both speeds (at level OK: the machine's state, not the robot's); the lifetime average
    would still read above 3."""
    clock = FakeClock()
    pacer = Pacer(4.0, now=clock, window=5.0)
    run(pacer, clock, 4000, cost=0.0003)
    slow = run(pacer, clock, 4000, cost=0.0025, start=4000)
    assert slow[-1] == pytest.approx(2.0, rel=0.02)
    c = pace_check(slow[-1], 4.0)
    assert c.level == OK and "does not keep up" in c.message
    assert "2.00x" in c.message and "4x asked" in c.message
    assert dict(c.values) == {"real-time factor": "%g" % slow[-1], "asked speed": "4"}


def test_pace_check_levels():
    assert pace_check(None, 4.0).level == OK
    assert pace_check(3.7, 4.0).message == "3.70x real time (4x asked)"    # within 10 %
    slow = pace_check(3.5, 4.0)
    assert slow.level == OK and "below 90% of the 4x asked" in slow.message
    c = pace_check(0.5, 0.0)                          # as fast as possible: never slow
    assert c.level == OK and dict(c.values)["asked speed"] == "as fast as possible"


def scans(meter, t0, t1, hz, not_cast_until=None):
    """Ticks a meter as the simulator's loop does at each laser tick in [t0, t1) at hz:
    restart() where no scan is cast (before not_cast_until), tick(stamp) otherwise;
    returns the ticks not cast."""
    not_cast = 0
    for k in range(int(round((t1 - t0) * hz))):
        t = t0 + k / hz
        if not_cast_until is not None and t < not_cast_until:
            meter.restart()
            not_cast += 1
        else:
            meter.tick(t)
    return not_cast


def test_scans_published_at_the_laser_rate_are_ok():
    m = RateMeter()
    scans(m, 10.0, 11.0, 40.0)
    c = published_rate_check(m.read(), 40.0, "scans", 0)
    assert c.level == OK and c.message == "40.0 Hz of scans published"
    assert dict(c.values)["scans published in window"] == "40"


def test_a_laser_nobody_subscribes_to_says_so_and_counts_nothing():
    m = RateMeter()
    not_cast = scans(m, 10.0, 11.0, 40.0, not_cast_until=11.0)
    c = published_rate_check(m.read(), 40.0, "scans", not_cast)
    assert c.level == OK and c.message == "no subscriber: scans not cast"
    assert dict(c.values)["scans published in window"] == "0"
    assert dict(c.values)["scans not cast (no subscriber)"] == "40"


def test_a_subscriber_connecting_mid_window_reads_the_laser_rate():
    m = RateMeter()
    not_cast = scans(m, 10.0, 11.0, 40.0, not_cast_until=10.5)
    c = published_rate_check(m.read(), 40.0, "scans", not_cast)
    assert c.level == OK and c.message.startswith("40.0 Hz")
    assert (dict(c.values)["scans published in window"], not_cast) == ("20", 20)


def test_messages_published_below_90_percent_warn_and_none_at_all_warns():
    m = RateMeter()
    scans(m, 10.0, 11.0, 30.0)
    c = published_rate_check(m.read(), 50.0, "odometry messages")
    assert c.level == WARN and "below 90% of the configured 50 Hz" in c.message
    assert "odometry messages not cast (no subscriber)" not in dict(c.values)
    c = published_rate_check(m.read(), 50.0, "odometry messages")
    assert c.level == WARN and c.message == "no odometry messages published since the last report"
