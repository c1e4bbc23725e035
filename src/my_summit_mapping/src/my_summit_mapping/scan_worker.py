"""A thread that hands queued scans to a SLAM core in order (no rospy).

A SLAM node's scan callbacks must return at once (rospy drops what its queues cannot
hold) while the core may take a long time on one scan: a just-in-time compilation at the
first scans, a loop closure's optimization over the whole graph. ScanWorker keeps the
scans with their odometry poses in a bounded queue and hands them to the core one at a
time, in their order, from a thread of its own.

    worker = ScanWorker(handle, max_pending=2400, on_dropped=..., on_error=...)
    worker.put(stamp, (odom, ranges, stamp))   # from any thread; handle(*item) runs later

When max_pending items wait already, the oldest is dropped and on_dropped(its key) called.
An exception from handle is given to on_error(traceback text) and the next item handled.
progress() tells how far the worker is (for a node's diagnostics). The thread is a
daemon: it ends with the process.
"""
import collections
import threading
import traceback


class ScanWorker:
    def __init__(self, handle, max_pending, on_dropped, on_error):
        self.handle, self.max_pending = handle, int(max_pending)
        self.on_dropped, self.on_error = on_dropped, on_error
        self.pending = collections.deque()   # (key, item)
        self.ready = threading.Condition()
        self.dropped = 0
        self.busy = None       # key of the item being handled
        self.last_done = None  # key of the item handled last
        self.handled = 0
        threading.Thread(target=self._run, daemon=True).start()

    def progress(self):
        """(dropped so far, items waiting, key of the item handled last or None, key of the
        oldest item not handled yet (being handled or queued) or None)."""
        with self.ready:
            oldest = self.busy if self.busy is not None else (self.pending[0][0] if self.pending else None)
            return self.dropped, len(self.pending), self.last_done, oldest

    def put(self, key, item):
        """Queue item (a tuple of handle's arguments) under key (e.g. the scan's stamp)."""
        dropped = None
        with self.ready:
            if len(self.pending) >= self.max_pending:
                dropped, _ = self.pending.popleft()
                self.dropped += 1
            self.pending.append((key, item))
            self.ready.notify_all()
        if dropped is not None:
            self.on_dropped(dropped)

    def wait_idle(self, timeout):
        """True when nothing waits or is being handled, within timeout [s, wall time]."""
        with self.ready:
            return self.ready.wait_for(lambda: not self.pending and self.busy is None, timeout)

    def _run(self):
        while True:
            with self.ready:
                while not self.pending:
                    self.ready.wait()
                key, item = self.pending.popleft()
                self.busy = key
            try:
                self.handle(*item)
            except Exception:  # noqa: BLE001 - reported through on_error, as rospy logs a callback's
                self.on_error(traceback.format_exc())
            finally:
                with self.ready:
                    self.busy, self.last_done = None, key
                    self.handled += 1
                    self.ready.notify_all()
