"""The filter's cycle as robot_localization's ekf_localization_node runs it (no rospy).

Messages arrive as lists of ekf.Measurement per topic (ekf_sensors); each periodic
update (`frequency` [Hz]) fuses the queued measurements whose stamps are not later than
now, in stamp order (predict to each, then correct); with none for `sensor_timeout` [s]
it predicts to now. What the node must say is returned as text, never raised:
  - a message with NaN or inf in a value it fuses, or in that value's variance, is
    dropped whole (the filter never sees it, so never outputs NaN);
  - a message stamped before the previous one on its topic is dropped (robot_localization
    does the same when it does not smooth lagged data);
  - a message stamped more than FUTURE_LIMIT ahead of now is dropped; one a little ahead
    waits in the queue until its time;
  - a rejected measurement (Mahalanobis threshold) is counted per topic;
  - with no measurement for sensor_timeout, the output is the state predicted to now
    (robot_localization predicts its filter itself; here the filter stays at its last
    measurement, so measurements that arrive late are still fused in stamp order);
  - a configured topic that has not published for `silent_after` [s] since the start is
    named once (the filter runs on the others);
  - a measurement stamped before the filter's time (lagged: it arrived after
    measurements stamped later were fused) is corrected without prediction, as
    robot_localization does by default; with `smooth_lagged_data` (robot_localization's
    parameter, history kept for `history_length` [s]) the filter is reverted to its state
    before the earliest lagged measurement and every measurement from there on is fused
    again in stamp order, so the result is what in-order arrival would have given.
"""
import collections
import heapq
import itertools
import math

import numpy as np

from summit_nav_common.diagnostic_checks import OK, WARN, Check, fmt

from .ekf import MIN_VARIANCE, STATE_NAMES, Ekf, Measurement

FUTURE_LIMIT = 1.0     # [s] a stamp this far ahead of now is taken for a wrong clock and dropped
SILENT_AFTER = 5.0     # [s] a topic without a message this long after the start is warned about


class EkfRunner:
    """Owns the Ekf, the measurement queue and the per-topic bookkeeping.

    config: ekf_config.EkfConfig; topics: the configured topics (for the silence check)."""

    def __init__(self, config, topics=(), silent_after=SILENT_AFTER):
        self.config = config
        self.ekf = Ekf(config.process_noise_covariance, config.initial_estimate_covariance, config.two_d_mode)
        self.queue = []                  # heap of (stamp, seq, Measurement, fused before a revert)
        self._seq = itertools.count()
        self.last_stamp = {t: None for t in topics}   # topic -> stamp [s] of its latest accepted message
        self.counts = {t: {"received": 0, "fused": 0, "rejected": 0, "dropped": 0} for t in topics}
        self.silent_after = silent_after
        self.start = None                # [s] time of the first update
        self.warned_silent = set()
        self.last_update = None          # [s] ROS time of the last measurement fused
        self.output = None               # (x, P, time) predicted past the filter after sensor_timeout
        # smooth_lagged_data: per fused measurement, in fusing order, (stamp, seq, measurement,
        # the filter before it: x, P, time, initialized); history_length [s] of it kept
        self.smooth = config.smooth_lagged_data
        self.history_length = config.history_length
        self.history = collections.deque()
        self.reverts = 0                 # cycles in which the filter went back for lagged measurements
        self.lagged = 0                  # cycles whose lagged measurements were fused where the filter was

    def _count(self, topic, key):
        self.counts.setdefault(topic, {"received": 0, "fused": 0, "rejected": 0, "dropped": 0})[key] += 1

    def add(self, topic, stamp, measurements, now):
        """Queues one message's measurements (stamp [s], now: the ROS time [s]); returns
        None, or the reason the whole message was dropped."""
        self._count(topic, "received")
        why = None
        if not math.isfinite(stamp):
            why = "its stamp is not a number"
        elif stamp > now + FUTURE_LIMIT:
            why = f"its stamp is {stamp - now:.3f} s in the future (more than {FUTURE_LIMIT:g} s)"
        elif self.last_stamp.get(topic) is not None and stamp < self.last_stamp[topic]:
            why = (f"its stamp {stamp:.3f} is before the previous message's {self.last_stamp[topic]:.3f} "
                   "(out of order)")
        else:
            for m in measurements:
                bad = not_finite(m)
                if bad:
                    why = f"{bad} is NaN or infinite"
                    break
        if why is not None:
            self._count(topic, "dropped")
            return why
        self.last_stamp[topic] = stamp
        for m in measurements:
            heapq.heappush(self.queue, (m.stamp, next(self._seq), m, False))
        return None

    def update(self, now):
        """Fuses the queued measurements stamped up to now [s]; predicts to now when none
        came for sensor_timeout. Returns the Outcomes of the rejected measurements as
        (topic, outcome) pairs."""
        if self.start is None:
            self.start = now
        rejected = []
        fused_any = False
        ekf = self.ekf
        if self.queue and ekf.initialized and self.queue[0][0] < ekf.time and self.queue[0][0] <= now:
            if self.smooth and self._revert(self.queue[0][0]):
                self.reverts += 1
            else:
                self.lagged += 1
                # fused where the filter is: its history is no longer in stamp order, so
                # it starts again from here
                self.history.clear()
        while self.queue and self.queue[0][0] <= now:
            stamp, seq, m, again = heapq.heappop(self.queue)
            if self.smooth:
                self.history.append((stamp, seq, m, ekf.x.copy(), ekf.P.copy(), ekf.time, ekf.initialized))
            outcome = ekf.process(m)
            fused_any = True
            if again:        # fused once more after a revert: counted the first time
                continue
            if outcome.accepted:
                self._count(m.source, "fused")
            else:
                self._count(m.source, "rejected")
                rejected.append((m.source, outcome))
        if fused_any:
            self.last_update = now
            self.output = None
            if self.smooth:
                keep_from = ekf.time - self.history_length
                while self.history and self.history[0][0] < keep_from:
                    self.history.popleft()
        elif self.ekf.initialized and self.last_update is not None \
                and now - self.last_update >= self.config.sensor_timeout:
            # Output predicted to now, the filter itself left at its last measurement: the
            # measurements of that gap may still be on their way (a busy machine delays
            # callbacks), and fused later they are predicted to in order instead of being
            # applied to a state already moved on with a stale turn rate.
            self.output = self.ekf.predicted(now)
        return rejected

    def _revert(self, stamp):
        """smooth_lagged_data: the filter back to its state before the first fused
        measurement stamped after `stamp` [s], and the measurements fused since queued
        again (with their order kept). False when the history does not reach back to
        stamp (the lagged measurement is then fused as without smoothing)."""
        h = self.history
        if not h or (h[0][0] > stamp and not (h[0][5] is not None and h[0][5] <= stamp)):
            return False
        k = len(h)
        while k > 0 and h[k - 1][0] > stamp:   # the lag is short: search from the newest
            k -= 1
        if k == len(h):
            return False                        # nothing fused after stamp (the filter only predicted past it)
        _, _, _, x, p, t, initialized = h[k]
        self.ekf.x, self.ekf.P, self.ekf.time, self.ekf.initialized = x, p, t, initialized
        while len(h) > k:
            st, seq, m = h.pop()[:3]
            heapq.heappush(self.queue, (st, seq, m, True))
        return True

    def state(self):
        """(x, P, time) to publish: the filter's, or its prediction after sensor_timeout
        without measurements; None before the first measurement."""
        if not self.ekf.initialized:
            return None
        if self.output is not None and self.output[2] > self.ekf.time:
            return self.output
        return self.ekf.x, self.ekf.P, self.ekf.time

    def silent_topics(self, now):
        """Configured topics with no message for silent_after [s] since the start that have
        not been named yet (each is returned once)."""
        if self.start is None or now - self.start < self.silent_after:
            return []
        out = [t for t, s in self.last_stamp.items()
               if s is None and self.counts[t]["received"] == 0 and t not in self.warned_silent]
        self.warned_silent.update(out)
        return out

    def set_pose(self, stamp, pose6, pose_cov6, sensors=()):
        """robot_localization's set_pose: the state becomes the pose (x, y, z, roll, pitch,
        yaw) with its 6x6 covariance, velocities and accelerations zero with the
        initial_estimate_covariance; queued measurements and the sensors' differential /
        relative references are dropped."""
        x = np.zeros(15)
        x[:6] = pose6
        p = self.config.initial_estimate_covariance.copy()
        p[:6, :] = 0.0
        p[:, :6] = 0.0
        p[:6, :6] = np.asarray(pose_cov6, dtype=np.float64).reshape(6, 6)
        np.fill_diagonal(p, np.maximum(np.abs(np.diagonal(p)), MIN_VARIANCE))
        self.ekf.reset(x, p, stamp)
        self.output = None
        self.queue.clear()
        self.history.clear()
        for s in sensors:
            s.reset()
        self.last_update = stamp


def not_finite(m: Measurement):
    """The first masked value of m (or its variance) that is not finite, as text; None
    when all are."""
    rows = m.cov[m.mask]
    if math.isfinite(m.z[m.mask].sum() + rows[:, m.mask].sum()):
        return None      # the common case in one test (a sum is finite only if every term is)
    for i in np.flatnonzero(m.mask):
        if not math.isfinite(m.z[i]):
            return f"{STATE_NAMES[i]}"
        if not np.all(np.isfinite(m.cov[i, m.mask])):
            return f"the covariance of {STATE_NAMES[i]}"
    return None


def status_check(r: EkfRunner, now):
    """The node's /diagnostics status "Filter": WARN while no measurement has come or a
    configured topic has been silent since the start (after silent_after [s]), else OK;
    per topic its messages received / fused / rejected / dropped; the lagged measurements."""
    values = [("filter time", fmt(r.ekf.time if r.ekf.time is not None else "none")),
              ("lagged measurements", f"{r.reverts} times gone back to fuse in stamp order (smooth_lagged_data), "
                                      f"{r.lagged} times fused where the filter was")]
    for topic, c in sorted(r.counts.items()):
        values.append((topic, f"received {c['received']}, fused {c['fused']}, rejected {c['rejected']}, "
                              f"dropped {c['dropped']}"))
    waited = r.start is not None and now - r.start >= r.silent_after
    silent = [t for t, s in r.last_stamp.items() if s is None]
    if not r.ekf.initialized:
        return Check(WARN if waited else OK, "no measurement yet", tuple(values))
    if silent and waited:
        return Check(WARN, f"no message on {', '.join(silent)}; filtering the other sensors", tuple(values))
    return Check(OK, "filtering", tuple(values))
