"""Pacing simulated time against the wall clock.

The simulator runs simulated time at most `speed` times the wall clock. A machine that
cannot keep up makes it slower, as Gazebo's real-time factor drops under load: lag up to
`max_lag` wall seconds (a laser tick's ray casting, scheduler jitter) is caught up, lag
beyond it is dropped. Catching up a long stall instead would burst seconds of scans and
odometry at nodes that were starved along with the simulator, and they would skip them
(SPEC: a node that cannot keep up must only slow the run, not break it).
"""
import time

# [s] of wall time the loop may run behind its schedule and still catch up.
MAX_LAG = 0.02


class Pacer:
    """When to simulate up to a simulated time, given the asked speed.

    speed: simulated seconds per wall second (<= 0: as fast as possible).
    now: the wall clock [s] (time.monotonic; a fake one in tests).
    """

    def __init__(self, speed, max_lag=MAX_LAG, now=time.monotonic):
        self.speed, self.max_lag, self.now = float(speed), float(max_lag), now
        self.start = self.origin = now()
        self.dropped = 0.0  # [s] wall time of lag given up so far

    def delay(self, sim_t):
        """Wall seconds to wait before going on past simulated time sim_t [s] (0 if late).

        Lag beyond max_lag is dropped here: the schedule moves later by it."""
        if self.speed <= 0:
            return 0.0
        ahead = self.origin + sim_t / self.speed - self.now()
        if ahead < -self.max_lag:
            late = -ahead - self.max_lag
            self.origin += late
            self.dropped += late
            return 0.0
        return max(ahead, 0.0)

    def summary(self, sim_t):
        """A line on the achieved speed when the asked one was not kept, else None."""
        wall = self.now() - self.start
        if self.speed <= 0 or wall <= 0 or self.dropped <= 0.05 * wall:
            return None
        return (f"ran {sim_t:.1f} s of simulated time in {wall:.1f} s wall: {sim_t / wall:.2f}x of the "
                f"{self.speed:g}x asked (the machine could not keep up; {self.dropped:.1f} s of lag dropped)")
