"""Unit tests of the frontier search (my_summit_navigation.frontiers)."""
import math

import numpy as np

from summit_nav_common.testing.scenes import known_corridor

from my_summit_navigation import frontiers as fr


def test_one_frontier_at_the_end_of_the_known_corridor():
    g = known_corridor()
    fs = fr.find_frontiers(g, 0.1, (0.0, 0.0), (0.5, 1.0), fr.FrontierParams(min_frontier_size=0.5))
    assert len(fs) == 1
    f = fs[0]
    assert math.isclose(f.size, 1.0, abs_tol=0.11)                # the 10-cell opening
    # goal_margin (0.3 m) back from the last known column (x 2.95), in the open corridor
    assert 2.6 <= f.goal[0] <= 2.8 and 0.7 <= f.goal[1] <= 1.3
    assert 1.9 <= f.distance <= 2.6                                # travel from x 0.5 to x 2.75
    edge = fr.find_frontiers(g, 0.1, (0.0, 0.0), (0.5, 1.0), fr.FrontierParams(min_frontier_size=0.5,
                                                                            goal_margin=0.0))
    assert 2.9 <= edge[0].goal[0] <= 3.0                           # explore_lite's goal: on the edge


def test_goal_steps_back_into_the_open_and_keeps_the_frontier_in_sight():
    # a room (rows 0..29, cols 0..29) known; its east wall (col 30) has a 0.4 m doorway at
    # rows 10..13 into a 0.4 m wide known passage (cols 31..35) ending in the unknown
    g = np.full((30, 50), -1, np.int16)
    g[:, :30] = 0
    g[:, 30] = 100
    g[10:14, 30:36] = 0
    g[9, 30:36] = 100
    g[14, 30:36] = 100
    fs = fr.find_frontiers(g, 0.1, (0.0, 0.0), (1.0, 1.5), fr.FrontierParams(min_frontier_size=0.3))
    assert len(fs) == 1
    gx, gy = fs[0].goal
    # nothing in the passage is 0.3 m from its walls: the goal is the widest spot in sight
    # of the edge cell, back in the room (x < 3.0), near the passage's axis (y 1.2)
    assert 2.0 <= gx < 3.0 and 0.9 <= gy <= 1.5
    # a wall just west of the doorway at col 27, rows 0..20 hides the south-west part of
    # the room: the goal never goes behind it
    g[0:21, 27] = 100
    fs = fr.find_frontiers(g, 0.1, (0.0, 0.0), (1.0, 2.5), fr.FrontierParams(min_frontier_size=0.3, goal_search=2.0))
    gx, gy = fs[0].goal
    assert gx >= 2.75


def test_small_frontiers_blacklist_and_no_reach():
    g = known_corridor()
    assert fr.find_frontiers(g, 0.1, (0.0, 0.0), (0.5, 1.0), fr.FrontierParams(min_frontier_size=1.5)) == []
    fs = fr.find_frontiers(g, 0.1, (0.0, 0.0), (0.5, 1.0), fr.FrontierParams(min_frontier_size=0.5),
                           blacklist=[(2.95, 1.0)])
    assert fs == []
    g[5:15, 10] = 100     # a wall across the corridor: the frontier is out of reach
    assert fr.find_frontiers(g, 0.1, (0.0, 0.0), (0.5, 1.0), fr.FrontierParams(min_frontier_size=0.5)) == []


def test_cheapest_first_by_distance_and_size():
    g = np.full((40, 40), -1, np.int16)
    g[10:30, 10:30] = 0                  # a known square room, open on every side
    near = fr.find_frontiers(g, 0.1, (0.0, 0.0), (1.2, 2.0), fr.FrontierParams(min_frontier_size=0.5))
    assert len(near) == 4 or len(near) == 1   # four sides touch at the corners -> one 8-connected ring
    costs = [f.cost for f in near]
    assert costs == sorted(costs)


def test_travel_distance_goes_around_a_wall():
    reach = np.ones((40, 40), bool)
    reach[0:36, 20] = False              # a wall with a gap at the top rows 36..39
    d = fr.travel_distances(reach, (2, 10), 0.1)
    straight = 2.0
    assert d[2, 30] > straight + 5.0     # around the wall: about 3.4 up, 1 across, 3.4 down
    assert math.isfinite(d[2, 30]) and np.isinf(d[~reach]).all()


def test_coverage_of_a_half_known_world():
    world = np.full((20, 40), 100, np.int16)
    world[1:19, 1:39] = 0
    spawn = (1.0, 1.0, 0.0)
    slam = np.full((20, 40), -1, np.int16)
    slam[:, :20] = 0                       # the west half known, in the spawn-centred frame
    cov = fr.exploration_coverage(world, 0.1, (0.0, 0.0), spawn, slam, 0.1, (-1.0, -1.0))
    assert 0.5 <= cov <= 0.56
    assert fr.exploration_coverage(world, 0.1, (0.0, 0.0), spawn, world, 0.1, (-1.0, -1.0)) == 1.0


def test_stuck_watch_tells_a_stuck_robot_from_unreachable_goals():
    w = fr.StuckWatch(goals=3, distance=0.5)
    # wedged: three goals given up, the robot never out of a 0.5 m circle (it dithers)
    assert not w.given_up((1.0, 1.0))
    w.update((1.3, 1.2))
    assert not w.given_up((1.2, 1.1))
    assert w.given_up((0.9, 1.1))
    # moving on between give-ups: the goals were the problem, not the robot
    w = fr.StuckWatch(goals=3, distance=0.5)
    assert not w.given_up((1.0, 1.0))
    w.update((3.0, 1.0))        # drove off to another frontier...
    w.update((1.1, 1.0))        # ...and came back
    assert not w.given_up((1.1, 1.0))
    assert not w.given_up((1.0, 1.1))
    assert w.given_up((1.0, 1.0))
    # stuck_goals 0: never stuck
    w = fr.StuckWatch(goals=0)
    assert not any(w.given_up((0.0, 0.0)) for _ in range(5))


def test_a_frontier_behind_the_robot_is_not_in_view():
    # the laser sees +-135 deg; in_view keeps +-110 deg
    assert fr.in_view((0.0, 0.0, 0.0), (2.0, 0.5))
    assert fr.in_view((0.0, 0.0, 0.0), (-0.5, 2.0))             # 104 deg to the left
    assert not fr.in_view((0.0, 0.0, 0.0), (-2.0, 0.3))         # behind
    assert not fr.in_view((0.0, 0.0, math.pi / 2), (0.3, -2.0))  # behind a robot facing +y
    assert fr.in_view((0.0, 0.0, math.pi), (-2.0, 0.3))         # turned round: ahead
    assert fr.in_view((0.0, 0.0, 3.1), (-2.0, -0.1))            # across the +-pi seam
    assert fr.in_view((1.0, 1.0, 0.0), (1.0, 1.0))              # on the robot


def test_goal_heading_faces_a_frontier_travel_would_leave_behind():
    # the frontier ahead of the way there: arrive heading the way the robot drives
    assert math.isclose(fr.goal_heading((0.0, 0.0), (3.0, 0.0), (3.5, 0.5)), 0.0)
    # the spawn's rear wedge: the goal 0.1 m ahead, its frontier 1.5 m behind: face it
    yaw = fr.goal_heading((0.0, 0.0), (0.1, 0.0), (-1.4, 0.2))
    assert abs(math.remainder(yaw - math.atan2(0.2, -1.5), 2 * math.pi)) < 1e-9
    # a frontier off to the side within view (90 deg): still the travel heading
    assert math.isclose(fr.goal_heading((0.0, 0.0), (2.0, 0.0), (2.0, 1.5)), 0.0)


def test_goal_progress_stalled_time_of_the_active_goal():
    p = fr.GoalProgress(timeout=30.0)
    assert p.stalled(5.0) == 0.0                 # no goal
    p.start((5.0, 0.0), 0.0)
    assert p.stalled(3.0) == 0.0                 # no distance measured yet
    p.update(5.0, 0.0)
    assert p.stalled(4.0) == 4.0
    p.update(4.0, 6.0)                           # progress
    assert p.stalled(7.0) == 1.0
    p.start((-50.0, 0.0), 8.0)                   # another goal: its own clock
    p.update(50.0, 8.0)
    assert p.stalled(10.0) == 2.0
    p.start((5.0, 0.0), 10.0)                    # back to the first: 2 s active without progress so far
    assert p.stalled(10.0) == 2.0 and p.stalled(13.0) == 5.0


def test_goal_progress_survives_a_flickering_choice_of_goals():
    p = fr.GoalProgress(timeout=30.0, same=0.5)
    # goals A and B alternate every 2 s, the robot going nowhere: A keeps its watch and
    # is given up after 30 s of being active (60 s), not never
    a, b = (5.0, 0.0), (-50.0, 0.0)
    t, stuck = 0.0, False
    while t < 90.0 and not stuck:
        for goal in (a, b):
            p.start((goal[0] + 0.2, goal[1]) if t > 0 and goal is a else goal, t)
            stuck = p.update(5.0 if goal is a else 50.0, t)
            if stuck:
                break
            t += 2.0
    assert stuck and p.active[0] == a and 60.0 < t <= 66.0
    # the time B was active does not count for A
    p = fr.GoalProgress(timeout=30.0)
    assert not p.start(a, 0.0)
    assert not p.update(5.0, 0.0)
    assert not p.update(5.0, 10.0)
    assert not p.start(b, 10.0)
    assert not p.update(50.0, 25.0)
    assert p.start((5.3, 0.1), 25.0)            # A again, 0.32 m off: the same watch
    assert not p.update(5.0, 44.0)              # 10 s + 19 s active without progress
    assert p.update(5.0, 46.0)                  # 31 s
    # progress on A resets A's clock
    p = fr.GoalProgress(timeout=30.0)
    p.start(a, 0.0)
    p.update(5.0, 0.0)
    p.start(b, 1.0)
    assert p.start((5.3, 0.1), 1.0)
    assert not p.update(4.0, 5.0)               # 1 m closer: progress at 5 s
    assert not p.update(4.0, 30.0)
    assert p.update(4.0, 36.0)
    # an earlier goal sent again after more than timeout inactive starts afresh
    p = fr.GoalProgress(timeout=30.0)
    p.start(a, 0.0)
    p.update(5.0, 10.0)
    p.start(b, 11.0)
    assert not p.start(a, 100.0)
    assert not p.update(5.0, 100.0) and not p.update(5.0, 129.0)


def test_goal_progress_forgets_a_goal_given_up():
    p = fr.GoalProgress(timeout=30.0)
    p.start((5.0, 0.0), 0.0)
    p.update(5.0, 0.0)
    assert p.update(5.0, 31.0)                   # given up
    p.forget((5.1, 0.0))
    assert not p.start((5.0, 0.0), 40.0)         # sent again: a fresh watch
    assert not p.update(5.0, 40.0) and not p.update(5.0, 69.0) and p.update(5.0, 71.0)


def test_blacklist_gives_goals_without_progress_one_more_try():
    b = fr.Blacklist(radius=0.5)
    b.add((1.0, 0.0))                            # reached
    b.add((2.0, 0.0), no_progress=False)         # aborted by move_base
    b.add((3.0, 0.0), no_progress=True)          # no progress: a stall, maybe
    assert sorted(b) == [(1.0, 0.0), (2.0, 0.0), (3.0, 0.0)]
    assert b.second_chance() == [(3.0, 0.0)]
    assert sorted(b) == [(1.0, 0.0), (2.0, 0.0)]
    assert b.second_chance() == []               # nothing waits: exploration may end
    # the goal (its frontier moved a little) given up again: it stays for good
    b.add((3.2, 0.1), no_progress=True)
    assert b.second_chance() == [] and (3.2, 0.1) in list(b)
    # a goal given up for no progress elsewhere still gets its try
    b.add((9.0, 0.0), no_progress=True)
    assert b.second_chance() == [(9.0, 0.0)]


def test_a_released_goal_is_found_again():
    g = known_corridor()
    robot = (0.5, 1.0)
    first = fr.find_frontiers(g, 0.1, (0.0, 0.0), robot)
    assert len(first) == 1
    b = fr.Blacklist(radius=fr.FrontierParams().blacklist_radius)
    b.add(first[0].goal, no_progress=True)
    assert fr.find_frontiers(g, 0.1, (0.0, 0.0), robot, blacklist=b) == []
    b.second_chance()
    again = fr.find_frontiers(g, 0.1, (0.0, 0.0), robot, blacklist=b)
    assert [f.goal for f in again] == [first[0].goal]


def test_frontiers_out_of_reach_are_counted():
    g = known_corridor()
    robot = (0.5, 1.0)
    assert fr.frontiers_out_of_reach(g, 0.1, (0.0, 0.0), robot) == 0   # the one frontier is reachable
    g[5:15, 10] = 100                 # a wall across the corridor with a slot of 2 cells
    g[9:11, 10] = 99                  # the slot: inscribed, the robot centre cannot pass
    assert fr.find_frontiers(g, 0.1, (0.0, 0.0), robot) == []
    assert fr.frontiers_out_of_reach(g, 0.1, (0.0, 0.0), robot) == 1
    # too small to count
    assert fr.frontiers_out_of_reach(g, 0.1, (0.0, 0.0), robot, fr.FrontierParams(min_frontier_size=1.5)) == 0


def test_coverage_leaves_out_space_beyond_a_gap_narrower_than_the_robot():
    world = np.full((20, 40), 100, np.int16)
    world[1:19, 1:39] = 0
    world[:, 20] = 100
    world[9:12, 20] = 0                    # a 0.3 m slot between the two halves
    spawn = (1.0, 1.0, 0.0)
    slam = np.full((20, 40), -1, np.int16)
    slam[:, :19] = 0                       # the west half known (spawn-centred frame)
    assert fr.exploration_coverage(world, 0.1, (0.0, 0.0), spawn, slam, 0.1, (-1.0, -1.0)) < 0.6
    # a robot of radius 0.3 m cannot pass the slot: the west half is all it can reach,
    # and its walls' neighbours count up to the wall
    assert fr.exploration_coverage(world, 0.1, (0.0, 0.0), spawn, slam, 0.1, (-1.0, -1.0),
                                   robot_radius=0.3) == 1.0
    # with a slot wide enough it can
    world[5:16, 20] = 0
    assert fr.exploration_coverage(world, 0.1, (0.0, 0.0), spawn, slam, 0.1, (-1.0, -1.0),
                                   robot_radius=0.3) < 0.6
