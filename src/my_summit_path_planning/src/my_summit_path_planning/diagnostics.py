"""move_base's diagnostic checks (pure): control loop, global planner, costmaps, recovery.

The real move_base publishes no diagnostics; these are the checks the tutorial's
performance table asks an operator to watch (control rate >= 10 Hz, planning time
< 1.0 s), each published as "move_base: <name>". Key names are a contract with the health
report (nav_health reads "rate [Hz]" of "move_base: Controller" and "last plan time [s]",
"max plan time [s]", "plans" and "failed attempts" of "move_base: Global planner"): keep
them.

- controller_check: control cycles per second [Hz, ROS time] against controller_frequency
  while a goal is active; WARN below 90 %.
- planner_check: wall-clock time of the last makePlan and the longest; WARN when a plan
  took longer than PLAN_TIME_WARN or the last attempt found no plan.
- costmaps_check: each costmap's updates per second against its update_frequency; WARN
  below 90 % or when one has not updated in STALE_UPDATES periods.
- recovery_check: WARN while a recovery behaviour runs, with its name.
"""
import threading

from summit_nav_common.diagnostic_checks import MIN_RATE_RATIO, OK, WARN, Check, RateReading, fmt

PLAN_TIME_WARN = 1.0   # [s] wall: a slower plan is a warning (the tutorial's planning-time bound)
STALE_UPDATES = 5      # a costmap silent for this many update periods is not updating
HARDWARE_ID = "none"   # a software node: no device (diagnostic_updater's convention)


def controller_check(reading: RateReading, controller_frequency: float, active: bool,
                     min_ratio: float = MIN_RATE_RATIO) -> Check:
    """The control loop's rate. reading: a RateMeter over the cycles' start times [s, ROS
    time], restarted at each goal; controller_frequency [Hz]; active: a goal is being
    pursued now. Idle (no goal and no cycle since the last report): OK with rate 0."""
    rate = reading.rate
    values = (("rate [Hz]", fmt(float(rate or 0.0))),
              ("controller_frequency [Hz]", fmt(float(controller_frequency))),
              ("cycles", fmt(int(reading.events))),
              ("goal active", fmt(bool(active))))
    if rate is None:
        # no interval between two cycles of one goal ended in this window
        if not active:
            return Check(OK, "idle: no goal", values)
        if reading.events == 0:
            return Check(WARN, "no control cycle since the last report while a goal is active: the loop "
                               "is stalled", values)
        return Check(OK, "goal just started", values)
    if rate < min_ratio * controller_frequency:
        return Check(WARN, f"control loop at {rate:.1f} Hz, below {min_ratio:.0%} of controller_frequency "
                           f"{controller_frequency:g} Hz", values)
    return Check(OK, f"{rate:.1f} Hz", values)


class PlanTimes:
    """The global planner's attempts: add(seconds, ok) from the planner thread, read()
    from the diagnostics' (last [s] or None, longest [s], plans found, attempts that
    failed, the last attempt's failure reason or '')."""

    def __init__(self):
        self._lock = threading.Lock()
        self.last = None
        self.max = 0.0
        self.plans = 0
        self.failures = 0
        self.last_failure = ""

    def add(self, seconds: float, ok: bool, reason: str = "") -> None:
        with self._lock:
            self.last = seconds
            self.max = max(self.max, seconds)
            if ok:
                self.plans += 1
                self.last_failure = ""
            else:
                self.failures += 1
                self.last_failure = reason or "no plan"

    def read(self):
        with self._lock:
            return self.last, self.max, self.plans, self.failures, self.last_failure


def planner_check(last, longest: float, plans: int, failures: int, last_failure: str,
                  warn_time: float = PLAN_TIME_WARN) -> Check:
    """The global planner. last / longest: wall time [s] of the latest and the longest
    makePlan (last None before the first: both published "n/a", not a 0 s plan); plans:
    plans found; failures: attempts without a plan; last_failure: why the latest attempt
    found none ('' when it found one). A reader counts attempts by "plans" + "failed
    attempts" (nav_health samples "last plan time [s]" when that count changes)."""
    values = (("last plan time [s]", fmt(float(last)) if last is not None else "n/a"),
              ("max plan time [s]", fmt(float(longest)) if last is not None else "n/a"),
              ("plans", fmt(int(plans))),
              ("failed attempts", fmt(int(failures))))
    if last is None:
        return Check(OK, "no plan requested yet", values)
    if last_failure:
        return Check(WARN, f"the last planning failed: {last_failure}", values)
    if last > warn_time:
        return Check(WARN, f"the last plan took {last:.2f} s (more than {warn_time:g} s)", values)
    return Check(OK, f"last plan {last:.3f} s", values)


def costmaps_check(costmaps, now: float, min_ratio: float = MIN_RATE_RATIO) -> Check:
    """Each costmap's update rate. costmaps: [(name, RateReading of its updates [s, ROS
    time], update_frequency [Hz])]; now [s]. A costmap with update_frequency 0 updates
    once (a static map) and is only reported. WARN: no update yet, none for STALE_UPDATES
    periods, or a rate below min_ratio x update_frequency."""
    values, problems = [], []
    for name, reading, frequency in costmaps:
        values += [(f"{name} rate [Hz]", fmt(float(reading.rate or 0.0))),
                   (f"{name} update_frequency [Hz]", fmt(float(frequency)))]
        if frequency <= 0.0:
            continue
        if reading.last is None:
            problems.append(f"{name}: no update yet")
        elif now - reading.last > STALE_UPDATES / frequency:
            problems.append(f"{name}: no update for {now - reading.last:.1f} s")
        elif reading.rate is not None and reading.rate < min_ratio * frequency:
            problems.append(f"{name}: {reading.rate:.1f} Hz, below {min_ratio:.0%} of update_frequency "
                            f"{frequency:g} Hz")
    if problems:
        return Check(WARN, "; ".join(problems), tuple(values))
    return Check(OK, "updating at their update_frequency", tuple(values))


def recovery_check(running, count: int = 0) -> Check:
    """running: (number 0-based, total, name) of the recovery behaviour running now, or
    None; count: recovery behaviours started so far."""
    if running is None:
        return Check(OK, "no recovery running", (("recovery", "none"), ("recoveries started", fmt(int(count)))))
    idx, total, name = running
    return Check(WARN, f"recovery behaviour {idx + 1}/{total} running: {name}",
                 (("recovery", name), ("recoveries started", fmt(int(count)))))
