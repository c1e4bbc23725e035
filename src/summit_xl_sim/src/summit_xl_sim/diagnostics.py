"""The simulator's diagnostic checks (pure): does it keep up, and what it publishes.

The simulator makes its own clock, so a rate measured on it always equals the configured
one; what an operator needs to know is whether the simulation keeps the asked ~speed
against the wall clock (as Gazebo's real-time factor), and which of its sensor messages
actually go out. pace_check judges the real-time factor that summit_xl_sim.pace.Pacer
measures; published_rate_check judges a summit_nav_common.diagnostic_checks.RateMeter
ticked once per published scan or odometry tick, on the messages' stamps (a scan nobody
subscribes to is not cast, so it is not counted but reported as such).
"""
from typing import Optional

from summit_nav_common.diagnostic_checks import MIN_RATE_RATIO, OK, WARN, Check, RateReading, fmt

HARDWARE_ID = "summit_xl"


def pace_check(factor: Optional[float], speed: float, min_ratio: float = MIN_RATE_RATIO) -> Check:
    """The achieved real-time factor against the asked one.

    factor: simulated seconds per wall second over the last window (Pacer.factor; None:
    no wall time yet); speed: the asked ~speed (<= 0: as fast as possible).
    Always OK: a simulator that does not keep up slows simulated time down (SPEC: a busy
    machine slows the run, it does not break it), so every node still sees its rates of
    simulated time; that is the machine's state, not the robot's, and a WARN here would
    turn the whole Navigation Stack WARN whenever a laptop is busy. Below min_ratio x
    speed the message says so, for the operator who asked for the speed.
    """
    values = (("real-time factor", fmt(float(factor)) if factor is not None else "n/a"),
              ("asked speed", fmt(float(speed)) if speed > 0 else "as fast as possible"))
    if factor is None:
        return Check(OK, "no wall time measured yet", values)
    if speed <= 0:
        return Check(OK, f"{factor:.2f}x real time (as fast as possible)", values)
    if factor < min_ratio * speed:
        return Check(OK, f"running at {factor:.2f}x real time, below {min_ratio:.0%} of the {speed:g}x "
                         f"asked: the machine does not keep up (simulated time slows, nothing breaks)", values)
    return Check(OK, f"{factor:.2f}x real time ({speed:g}x asked)", values)


def published_rate_check(reading: RateReading, expected_hz: float, what: str,
                         not_cast: Optional[int] = None, min_ratio: float = MIN_RATE_RATIO) -> Check:
    """Messages published per simulated second against the configured rate.

    reading: a RateMeter ticked at the stamps [s] of the published messages, read once
    per report; expected_hz: the configured rate [Hz]; what: the messages ("scans");
    not_cast: ticks since the previous report at which nothing was published because no
    one subscribes (the meter restarted at each); None for messages published whether or
    not anyone subscribes (odometry). Nothing published and ticks not cast is
    OK ("no subscriber"). WARN: nothing published otherwise, or a rate below min_ratio x
    expected_hz.
    """
    values = (("rate [Hz]", fmt(float(reading.rate or 0.0))),
              ("expected rate [Hz]", fmt(float(expected_hz))),
              (f"{what} published in window", fmt(int(reading.events))))
    if not_cast is not None:
        values += ((f"{what} not cast (no subscriber)", fmt(int(not_cast))),)
    if reading.events == 0:
        if not_cast:
            return Check(OK, f"no subscriber: {what} not cast", values)
        return Check(WARN, f"no {what} published since the last report", values)
    if reading.rate is None:
        return Check(OK if not_cast else WARN, f"fewer than two {what} published since the last report", values)
    if reading.rate < min_ratio * expected_hz:
        return Check(WARN, f"{what} published at {reading.rate:.1f} Hz, below {min_ratio:.0%} of the "
                           f"configured {expected_hz:g} Hz", values)
    return Check(OK, f"{reading.rate:.1f} Hz of {what} published", values)
