"""summit_nav_common.ros.action_client: a server that answers before send_goal returns.

The story: in a repeat of get_coordinates_bad_input.test (tools/repeat_tests.py -n 4 -j 2,
beside a benchmark), move_base aborted the goal 'wall' (a spot inside a wall) 3 ms after
get_coordinates sent it; actionlib's SimpleActionClient logged "Got a transition callback
on a goal handle that we're not tracking" three times, never ran done_cb, and the
service call hung until rostest's 300 s limit. Here a fake ActionClient answers from
another thread while send_goal is still running, as move_base did.
"""
import threading

import actionlib
import actionlib.simple_action_client as sac
import pytest
from actionlib_msgs.msg import GoalStatus

from summit_nav_common.ros.action_client import SimpleActionClient


class DoneHandle:
    """A goal handle the server has already finished (aborted)."""

    def get_comm_state(self):
        return actionlib.CommState.DONE

    def get_goal_status(self):
        return GoalStatus.ABORTED

    def get_result(self):
        return None


class FastServer:
    """Stands in for actionlib.ActionClient: the answer comes, in the subscriber's
    thread, before send_goal has returned the new goal's handle."""

    def __init__(self, ns, _spec):
        self.ns = ns

    def send_goal(self, _goal, transition_cb, _feedback_cb):
        gh = DoneHandle()
        t = threading.Thread(target=transition_cb, args=(gh,), daemon=True)
        t.start()
        t.join(0.2)   # the answer is handled (or waits) while send_goal still runs
        return gh


def send_to_fast_server(cls, monkeypatch):
    monkeypatch.setattr(sac, "ActionClient", FastServer)
    client = cls("move_base", object)
    done = threading.Event()
    states = []
    client.send_goal(object(), done_cb=lambda state, _result: (states.append(state), done.set()))
    return client, done, states


def test_an_answer_before_send_goal_returns_is_not_lost(monkeypatch):
    client, done, states = send_to_fast_server(SimpleActionClient, monkeypatch)
    assert done.wait(2.0), "done_cb never ran: the early answer was dropped"
    assert states == [GoalStatus.ABORTED]
    assert client.simple_state == sac.SimpleGoalState.DONE
    assert client.get_state() == GoalStatus.ABORTED


def test_actionlib_own_client_loses_it(monkeypatch):
    """The race this module exists for. If this fails, actionlib has fixed it and
    summit_nav_common.ros.action_client can go."""
    client, done, _ = send_to_fast_server(actionlib.SimpleActionClient, monkeypatch)
    assert not done.wait(0.5)
    assert client.simple_state == sac.SimpleGoalState.PENDING


if __name__ == "__main__":
    pytest.main([__file__])
