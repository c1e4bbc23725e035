"""Parameter names a node does not read: left unread, as the real ROS nodes leave them, and said once.

A roscpp node asks the parameter server for the names it knows and never looks at the
others, so a foreign or misspelt name in a launch file or YAML does nothing there. Robot
vendors' configurations carry such names (husky_navigation's planner.yaml sets
``recovery_behaviour_enabled``, jackal_navigation's costmap file ``meter_scoring``), and
the real nodes run with them. Ours run with them too, and log one warning per name, with
the nearest name the node does read, so that a typo does not go unnoticed.
"""
import difflib


def unread_names(params, known):
    """The keys of the dict `params` that are not in `known`, sorted."""
    known = set(known)
    return sorted(str(k) for k in params if k not in known)


def unread_note(where, name, known):
    """The warning for one unread name: where it is (none when `where` is empty: the
    logger says it), that it is ignored, the nearest known name."""
    near = difflib.get_close_matches(str(name), sorted(known), n=1)
    hint = f" (did you mean '{near[0]}'?)" if near else ""
    return f"{where + ': ' if where else ''}'{name}' is not a parameter this node reads; ignored{hint}"


def unread_notes(where, params, known):
    """unread_note for each unread name of `params`, in name order."""
    return [unread_note(where, k, known) for k in unread_names(params, known)]
