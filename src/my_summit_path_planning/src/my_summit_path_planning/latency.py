"""The control loop's measured latency, which the local planners brake for.
"""
import collections

class LatencyMeter:
    """Control-loop latency: the longest interval between control cycles over the last
    `window` cycles. On a loaded machine (or a simulator faster than real time) the loop
    runs late and each command stays in force longer than one period; DWA brakes for that
    (DWAPlanner.set_control_latency). A gap of `pause` [s] or more is a pause between
    goals, not latency."""

    def __init__(self, window, pause=2.0):
        self.intervals = collections.deque(maxlen=max(1, int(window)))
        self.pause = float(pause)
        self.last = None

    def reset(self):
        self.intervals.clear()
        self.last = None

    def update(self, now):
        """A control cycle at time now [s]; returns the latency [s], or None before two cycles."""
        if self.last is not None and 0.0 < now - self.last < self.pause:
            self.intervals.append(now - self.last)
        self.last = now
        return max(self.intervals) if self.intervals else None
