"""Pacing simulated time against the wall clock.

The simulator runs simulated time at most `speed` times the wall clock. A machine that
cannot keep up makes it slower, as Gazebo's real-time factor drops under load: lag up to
`max_lag` wall seconds (a laser tick's ray casting, scheduler jitter) is caught up, lag
beyond it is dropped. Catching up a long stall instead would burst seconds of scans and
odometry at nodes that were starved along with the simulator, and they would skip them
(SPEC: a node that cannot keep up must only slow the run, not break it).

Pacer.factor reports the speed achieved (the real-time factor, simulated seconds per wall
second) over the last few wall seconds, for the simulator's /diagnostics.
"""
import collections
import time

# [s] of wall time the loop may run behind its schedule and still catch up.
MAX_LAG = 0.02
# [s] of wall time over which factor() measures the achieved speed: long against MAX_LAG
# and the scheduler's jitter (0.4 % at most from a lag still to catch up), short enough
# that a slowdown shows within seconds.
FACTOR_WINDOW = 5.0


class Pacer:
    """When to simulate up to a simulated time, given the asked speed.

    speed: simulated seconds per wall second (<= 0: as fast as possible).
    now: the wall clock [s] (time.monotonic; a fake one in tests).
    """

    def __init__(self, speed, max_lag=MAX_LAG, now=time.monotonic, window=FACTOR_WINDOW):
        self.speed, self.max_lag, self.now = float(speed), float(max_lag), now
        self.start = self.origin = now()
        self.dropped = 0.0  # [s] wall time of lag given up so far
        self.window = float(window)
        self._marks = collections.deque([(self.start, 0.0)])  # (wall [s], sim_t [s]) at factor() calls

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

    def factor(self, sim_t):
        """The achieved speed [simulated s / wall s] up to simulated time sim_t [s], over the
        calls of about the last `window` wall seconds (since the start until one window has
        passed); None when no wall time has passed. Called once per report: a call keeps
        one mark, and marks older than the window are dropped."""
        wall = self.now()
        marks = self._marks
        marks.append((wall, float(sim_t)))
        while len(marks) > 2 and marks[1][0] <= wall - self.window:
            marks.popleft()
        wall0, sim0 = marks[0]
        return (sim_t - sim0) / (wall - wall0) if wall > wall0 else None

    def summary(self, sim_t):
        """A line on the achieved speed when the asked one was not kept, else None."""
        wall = self.now() - self.start
        if self.speed <= 0 or wall <= 0 or self.dropped <= 0.05 * wall:
            return None
        return (f"ran {sim_t:.1f} s of simulated time in {wall:.1f} s wall: {sim_t / wall:.2f}x of the "
                f"{self.speed:g}x asked (the machine could not keep up; {self.dropped:.1f} s of lag dropped)")
