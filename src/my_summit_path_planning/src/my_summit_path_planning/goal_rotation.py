"""Turning on the spot to the goal heading (base_local_planner's rotateToGoal, time-optimal).
"""
import math

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
