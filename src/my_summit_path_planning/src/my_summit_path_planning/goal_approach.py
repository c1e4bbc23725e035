"""The steps of a local planner at the goal: braking, and turning on the spot to its heading.

Once the robot is within xy_goal_tolerance, base_local_planner's planners stop the
translation as hard as the acceleration limits allow (stopWithAccLimits: ``braked``) and
then turn on the spot to the goal heading (rotateToGoal). Two turn laws, one per planner:
- ``rotate_to_goal_speed``: base_local_planner's rotateToGoal as TrajectoryPlannerROS
  runs it (a proportional law, no slower than min_in_place_vel_theta, within the
  acceleration window, capped by sqrt(2 acc |err|));
- ``rotation_speed``: ours for DWAPlannerROS, time-optimal (bang-bang) with the command's
  real period (``held_turn``), which keeps a late control loop from overshooting.
"""
import math


def braked(v, acc, dt):
    """stopWithAccLimits for one axis: the speed [same unit as v] after braking v as hard
    as acc [per s] allows over dt [s], never past zero."""
    return math.copysign(max(0.0, abs(v) - acc * dt), v)


def rotate_to_goal_speed(err, vth, acc, max_vel, min_vel, min_in_place_vel, dt):
    """base_local_planner's rotateToGoal: the in-place turn rate [rad/s] toward a heading err
    [rad] away from vth [rad/s] now: min(max_vel, |err|) but no slower than
    min_in_place_vel, within vth +- acc dt, no faster than sqrt(2 acc |err|) (able to stop
    at the heading), then clamped to [min_in_place_vel, max_vel] (min_vel <= -min_in_place_vel
    for a negative turn)."""
    if err > 0.0:
        w = min(max_vel, max(min_in_place_vel, err))
    else:
        w = max(min_vel, min(-min_in_place_vel, err))
    sign = -1.0 if w < 0.0 else 1.0       # base_local_planner's sign(): +1 at 0
    lo, hi = abs(vth) - acc * dt, abs(vth) + acc * dt
    w = sign * min(max(abs(w), lo), hi)
    sign = -1.0 if w < 0.0 else 1.0
    w = sign * min(math.sqrt(2.0 * acc * abs(err)), abs(w))
    return min(max_vel, max(min_in_place_vel, w)) if w > 0.0 else max(min_vel, min(-min_in_place_vel, w))

def held_turn(v, w, acc, dt):
    """The angle [rad] a base turning at w [rad/s] covers when v [rad/s] (same sign, >= 0
    here) is commanded and held for dt [s] while the base ramps toward it at acc
    [rad/s^2], and then braked to rest at acc."""
    t_ramp = min(dt, abs(v - w) / acc)
    reached = w + math.copysign(acc * t_ramp, v - w)
    held = 0.5 * (w + reached) * t_ramp + reached * (dt - t_ramp)
    return held + reached * reached / (2.0 * acc)


def rotation_speed(err, vth, acc, max_vel, min_vel, tolerance, dt):
    """Signed in-place turn rate [rad/s] toward a heading err [rad] away (time-optimal).

    base_local_planner's rotateToGoal turns at min(max_vel_theta, |err|) rad/s (a
    proportional law: the last radian takes seconds) capped by sqrt(2 acc |err|); here
    the bang-bang profile: the fastest command (<= max_vel, and no more than the base
    reaches within dt) that, held for the period dt [s] the command stays in force (one
    control period, or the measured latency of a late loop) while the base ramps toward
    it at acc [rad/s^2], can still be braked at acc to stop half a tolerance short of
    the heading (held_turn). Never slower than min_vel [rad/s] outside the tolerance (the
    base would not move), unless min_vel held for dt would carry the heading past the far
    edge of the tolerance: a late loop at min_vel would then turn back and forth across
    it until move_base gives up.
    """
    e = abs(err)
    w = abs(vth) if vth * err > 0 else 0.0          # current speed toward the heading
    target = max(0.0, e - 0.5 * tolerance)
    lo, hi = 0.0, min(max_vel, w + acc * dt)        # no faster than the base reaches within dt
    if held_turn(hi, w, acc, dt) > target:
        for _ in range(40):                         # held_turn grows with v: bisection
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if held_turn(mid, w, acc, dt) <= target else (lo, mid)
    else:
        lo = hi
    floor = min_vel if held_turn(min_vel, w, acc, dt) <= e + tolerance else 0.0
    return math.copysign(max(floor, lo), err)
