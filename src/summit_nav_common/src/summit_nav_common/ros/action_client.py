"""actionlib's SimpleActionClient without the race that loses a fast server's answer.

SimpleActionClient.send_goal stores the new goal's handle only after
ActionClient.send_goal has published the goal. A server that answers first (move_base
rejects a goal in a wall within a few milliseconds, as the real one does) has its status
and result handled in the subscriber thread while the client still holds the previous
handle: the transition is dropped with "Got a transition callback on a goal handle that
we're not tracking", done_cb never runs and wait_for_result waits forever.

Here send_goal holds a lock until the handle is stored, and the transition and feedback
callbacks pass that lock before SimpleActionClient looks at the handle: an answer that
comes early waits the few microseconds until send_goal has returned.
"""
import threading

import actionlib


class SimpleActionClient(actionlib.SimpleActionClient):
    """Drop-in for actionlib.SimpleActionClient (same constructor and methods)."""

    def __init__(self, ns, action_spec):
        self._handle_lock = threading.RLock()
        super().__init__(ns, action_spec)

    def send_goal(self, goal, done_cb=None, active_cb=None, feedback_cb=None):
        with self._handle_lock:
            super().send_goal(goal, done_cb, active_cb, feedback_cb)

    def _handle_transition(self, gh):
        with self._handle_lock:
            pass    # send_goal has stored this goal's handle
        super()._handle_transition(gh)

    def _handle_feedback(self, gh, feedback):
        with self._handle_lock:
            pass
        super()._handle_feedback(gh, feedback)
