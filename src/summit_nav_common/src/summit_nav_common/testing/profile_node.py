#!/usr/bin/python3
"""Run a rospy node under cProfile in every thread, counting CPU time (not wall time).

    profile_node.py [--all-threads] OUT_PREFIX NODE_SCRIPT [node args...]
    (as a roslaunch launch-prefix: launch_prefix("/tmp/amcl"), which names this file)

rospy runs each subscription's receive loop (socket read, deserialization, the user's
callbacks) in a thread of its own, which `python3 -m cProfile` does not see. Here every
message received is profiled in its thread, with time.thread_time as the clock, so a
blocking socket read costs nothing and what is left is the CPU spent per topic. With
--all-threads the node's main thread (a simulator's loop runs there) and every thread it
starts (threading.Thread: update loops, planner and control threads, action servers) are
profiled from their start, and read at exit while they still run (calls still in
progress then are not counted). At exit (roslaunch's SIGINT ends rospy.spin) the node
writes:
  OUT_PREFIX.pstats        all threads' profiles merged (pstats.Stats(path))
  OUT_PREFIX.threads.json  {native thread id: topic name} of the receive threads (and
                           class, name and target of the others still running), so
                           /proc/<pid>/task/<tid>/stat can be read per topic
"""
import atexit
import cProfile
import json
import os
import pstats
import runpy
import sys
import threading
import time


class _Snapshot:
    """A profile's statistics so far, for pstats, without stopping it (a thread still runs)."""

    def __init__(self, prof):
        prof.snapshot_stats()
        self.stats = prof.stats

    def create_stats(self):
        pass


def launch_prefix(out_prefix, all_threads=False):
    """A roslaunch launch-prefix that runs a node under this tool, its profile at out_prefix.
    OPENBLAS_NUM_THREADS as our nodes set it for themselves: the profiler's rospy import
    loads numpy before the node's first line runs."""
    return (f"env OPENBLAS_NUM_THREADS=1 /usr/bin/python3 {os.path.abspath(__file__)} "
            + ("--all-threads " if all_threads else "") + out_prefix)


def child_run(run_once, args, tmp_prefix, summary, limit=30):
    """One benchmark run in this process (rospy joins one master per process):
    run_once(index, args, folder) -> dict; its profile, if any, printed and summed up
    by summary(path) into profile_shares; the dict printed as JSON on the last line."""
    import tempfile
    if args.profile:  # keep the launch log beside the profile
        r = run_once(args.run_index, args, os.path.abspath(args.profile))
    else:
        with tempfile.TemporaryDirectory(prefix=tmp_prefix) as tmp:
            r = run_once(args.run_index, args, tmp)
    if r.get("profile") and os.path.exists(r["profile"] + ".pstats"):
        print_profile(r["profile"] + ".pstats", limit)
        r["profile_shares"] = summary(r["profile"] + ".pstats")
    print("\n" + json.dumps(r), flush=True)
    return 0


def run_child(cmd, index):
    """Run one child_run process; returns its JSON result (its other output printed).
    Stopped (SIGTERM after roslaunch_session.exit_on_sigterm, Ctrl-C), the child is given
    the time to stop the graph it started (roslaunch_session.run_child_process)."""
    from summit_nav_common.testing.roslaunch_session import run_child_process
    returncode, out = run_child_process(cmd)
    start = out.rfind("\n{")
    if returncode != 0 or start < 0:
        print(out)
        raise RuntimeError(f"run {index} failed (exit {returncode})")
    print(out[:start])
    return json.loads(out[start + 1:])


def stage_shares(path, stages, contains, other="other"):
    """{stage: share of the profiled CPU} of a profile written by this tool.

    stages: [(name, [(file suffix, function name), ...])]: a stage's figure is the
    cumulative CPU of those functions (each call counted once when they call each other); contains: {stage index: [indices of the stages that
    run inside it]}, subtracted from it. What no stage covers is `other`. Shares, not
    seconds: the profiler slows everything."""
    stats = pstats.Stats(path).stats
    total = sum(v[2] for v in stats.values())   # own times add up to the profiled CPU

    def cum(keys):
        """Cumulative CPU of the matching functions, entered from outside them: a match
        called by another match (rospy's Publisher.publish calls its impl's publish) is
        already inside the caller's figure."""
        matched = {k for k in stats if any(k[0].endswith(suffix) and k[2] == fn for suffix, fn in keys)}
        out = 0.0
        for k in matched:
            ct, callers = stats[k][3], stats[k][4]
            out += ct - sum(v[3] for c, v in callers.items() if c in matched and c != k)
        return out

    raw = [cum(keys) for _, keys in stages]
    own = [raw[i] - sum(raw[j] for j in contains.get(i, ())) for i in range(len(raw))]
    shares = {name: round(max(v, 0.0) / total, 3) for (name, _), v in zip(stages, own)}
    shares[other] = round(max(0.0, 1.0 - sum(shares.values())), 3)
    return shares


def print_profile(path, limit=30):
    """The profile's top functions by cumulative and by own CPU time."""
    st = pstats.Stats(path)
    print(f"\n--- {path}: by cumulative CPU time ---")
    st.sort_stats("cumulative").print_stats(limit)
    print(f"--- {path}: by own CPU time ---")
    st.sort_stats("tottime").print_stats(limit)


def main():
    all_threads = len(sys.argv) > 1 and sys.argv[1] == "--all-threads"
    if all_threads:
        del sys.argv[1]
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    out_prefix, script = sys.argv[1], sys.argv[2]
    sys.argv = sys.argv[2:]
    from rospy.impl import tcpros_base
    from rospy import topics

    profiles = []               # (Profile, state dict) of every thread seen
    lock = threading.Lock()
    local = threading.local()
    stopping = threading.Event()
    names = {}

    def profiler():
        if not hasattr(local, "prof"):
            local.prof = cProfile.Profile(time.thread_time)
            local.state = {"active": False}
            with lock:
                profiles.append((local.prof, local.state))
        return local.prof

    def profiled(fn):
        def wrapper(*args, **kwargs):
            prof = profiler()
            if stopping.is_set() or local.state["active"]:
                return fn(*args, **kwargs)
            local.state["active"] = True
            prof.enable()
            try:
                return fn(*args, **kwargs)
            finally:
                prof.disable()
                local.state["active"] = False
        return wrapper

    orig_loop = tcpros_base.TCPROSTransport.receive_loop

    def receive_loop(self, msgs_callback):
        names[threading.get_native_id()] = self.name
        return orig_loop(self, msgs_callback)

    tcpros_base.TCPROSTransport.receive_loop = receive_loop
    if all_threads:
        # Threads the node starts itself (a costmap's update loop, a planner or control
        # thread, an action server's execute thread) are profiled for their whole life;
        # the dump reads them while they still run.
        orig_run = threading.Thread.run

        def run(self):
            names[threading.get_native_id()] = f"{type(self).__name__} {self.name}"  # a receive loop renames it
            prof = profiler()
            local.state["whole_thread"] = True
            local.state["active"] = True
            prof.enable()
            try:
                return orig_run(self)
            finally:
                prof.disable()
                local.state["active"] = False

        threading.Thread.run = run
    tcpros_base.TCPROSTransport.receive_once = profiled(tcpros_base.TCPROSTransport.receive_once)
    topics._SubscriberImpl.receive_callback = profiled(topics._SubscriberImpl.receive_callback)

    def dump():
        stopping.set()
        time.sleep(0.2)  # let calls in flight finish
        with lock:
            done = [p for p, st in profiles if not st["active"]]
            running = [p for p, st in profiles if st["active"] and st.get("whole_thread")]
        stats = None
        for p in done + running:
            if p in running:
                p = _Snapshot(p)
            else:
                p.create_stats()
            if not p.stats:
                continue
            stats = pstats.Stats(p) if stats is None else stats.add(p)
        if stats is not None:
            stats.dump_stats(out_prefix + ".pstats")
        for t in threading.enumerate():  # the other threads: publishers' queues, timers
            if t.native_id is not None and t.native_id not in names:
                target = getattr(t, "_target", None)
                names[t.native_id] = f"{type(t).__name__} {t.name}" + (
                    f" ({getattr(target, '__qualname__', target)})" if target is not None else "")
        with open(out_prefix + ".threads.json", "w") as f:
            json.dump({"pid": os.getpid(), "threads": {str(k): v for k, v in names.items()}}, f)

    atexit.register(dump)
    if not all_threads:
        runpy.run_path(script, run_name="__main__")
        return
    # The node's main thread too (a simulator's or a driver's loop runs there).
    names[threading.get_native_id()] = "main thread"
    prof = profiler()
    local.state["active"] = True
    prof.enable()
    try:
        runpy.run_path(script, run_name="__main__")
    finally:
        prof.disable()
        local.state["active"] = False


if __name__ == "__main__":
    main()
