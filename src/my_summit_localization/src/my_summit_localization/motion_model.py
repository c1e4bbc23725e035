"""amcl's sample motion models (odometry), vectorized over the whole particle set.

Algorithm: sample_motion_model_odometry (Thrun, Burgard, Fox, Probabilistic Robotics,
ch. 5.4, table 5.6) as ROS amcl implements it in ``AMCLOdom::UpdateAction``
(amcl/src/amcl/sensors/amcl_odom.cpp), with its four models:

``diff`` (two-wheel / skid steer), from the odometry increment (dx, dy, dyaw) taken in
the odom frame between the last filter update and now::

    rot1  = angle_diff(atan2(dy, dx), yaw_old)     (0 when the move is < 1 cm)
    trans = hypot(dx, dy)
    rot2  = angle_diff(dyaw, rot1)
    r1n, r2n = rot1, rot2 folded so backward motion counts as forward (min |.|, |.-pi|)
    sd_rot1  = a1*r1n^2 + a2*trans^2
    sd_trans = a3*trans^2 + a4*r1n^2 + a4*r2n^2
    sd_rot2  = a1*r2n^2 + a2*trans^2
    rot1^ = rot1 - N(sd_rot1); trans^ = trans - N(sd_trans); rot2^ = rot2 - N(sd_rot2)
    x += trans^ cos(yaw + rot1^); y += trans^ sin(yaw + rot1^); yaw += rot1^ + rot2^

``omni`` (mecanum / holonomic)::

    trans = hypot(dx, dy), rot = dyaw, bearing = angle_diff(atan2(dy, dx), yaw_old) + yaw
    sd_trans = a3*trans^2 + a1*rot^2;  sd_rot = a4*rot^2 + a2*trans^2
    sd_strafe = a1*rot^2 + a5*trans^2
    trans^ = trans + N(sd_trans); rot^ = rot + N(sd_rot); strafe^ = N(sd_strafe)
    x += trans^ cos(b) + strafe^ sin(b); y += trans^ sin(b) - strafe^ cos(b); yaw += rot^

The quirk kept on purpose: in ``diff`` and ``omni`` amcl passes ``alpha * delta^2`` as
the *standard deviation* of the Gaussian (so the noise grows with the square of the
motion and the alphas are not the variances of Probabilistic Robotics). The
``diff-corrected`` and ``omni-corrected`` models take the square root, ``sd =
sqrt(alpha * delta^2)``, which is Probabilistic Robotics' variance form; amcl's wiki
advises smaller alphas for them. N(sd) is a zero-mean Gaussian sample of std sd.

Deliberately not copied from amcl: its motion update resets every weight to 1/N (a
known quirk that throws away the last sensor update when resample_interval > 1); here
the weights are left to the filter. amcl's ``backwards`` branch in ``diff`` is dead code
(its signed translation is a norm, never negative) and is omitted without changing the
result.

Units: poses (x [m], y [m], yaw [rad]); particles an (N, 3) float64 array.
"""
import numpy as np

from summit_nav_common.geometry import angle_diff, wrap_angle

# Below this odometry translation [m] the bearing of the move is meaningless (in-place
# rotation) and amcl's diff model sets rot1 = 0.
MIN_TRANS_FOR_BEARING = 0.01

MODELS = ("diff", "omni", "diff-corrected", "omni-corrected")


def odom_delta(odom_pose, last_odom_pose):
    """amcl's odometry increment (dx [m], dy [m], dyaw [rad]) in the *odom* frame.

    dx, dy: plain differences of positions; dyaw: angle_diff of the headings. This is
    what amcl's update gating (update_min_d per axis, update_min_a) tests.
    """
    return np.array([odom_pose[0] - last_odom_pose[0], odom_pose[1] - last_odom_pose[1],
                     float(angle_diff(odom_pose[2], last_odom_pose[2]))])


def _fold_backward(rot):
    """|rot| folded so rotating by rot or rot +- pi counts the same (backward motion)."""
    return min(abs(float(angle_diff(rot, 0.0))), abs(float(angle_diff(rot, np.pi))))


def diff_noise_std(delta, old_yaw, alphas, corrected=False):
    """(rot1, trans, rot2) and their noise std (sd_rot1, sd_trans, sd_rot2) [rad, m, rad].

    delta: odom increment (dx, dy, dyaw) in the odom frame; old_yaw: odom heading at the
    last update [rad]; alphas: (a1, a2, a3, a4, a5). corrected: sqrt of amcl's terms.
    """
    a1, a2, a3, a4 = alphas[:4]
    dx, dy, dyaw = float(delta[0]), float(delta[1]), float(delta[2])
    trans = float(np.hypot(dx, dy))
    rot1 = 0.0 if trans < MIN_TRANS_FOR_BEARING else float(angle_diff(np.arctan2(dy, dx), old_yaw))
    rot2 = float(angle_diff(dyaw, rot1))
    r1n, r2n = _fold_backward(rot1), _fold_backward(rot2)
    sd = np.array([a1 * r1n ** 2 + a2 * trans ** 2,
                   a3 * trans ** 2 + a4 * r1n ** 2 + a4 * r2n ** 2,
                   a1 * r2n ** 2 + a2 * trans ** 2])
    if corrected:
        sd = np.sqrt(sd)
    return (rot1, trans, rot2), sd


def omni_noise_std(delta, alphas, corrected=False):
    """(trans, rot) and noise std (sd_trans [m], sd_rot [rad], sd_strafe [m]) of omni."""
    a1, a2, a3, a4, a5 = alphas
    trans = float(np.hypot(delta[0], delta[1]))
    rot = float(delta[2])
    sd = np.array([a3 * trans ** 2 + a1 * rot ** 2,
                   a4 * rot ** 2 + a2 * trans ** 2,
                   a1 * rot ** 2 + a5 * trans ** 2])
    if corrected:
        sd = np.sqrt(sd)
    return (trans, rot), sd


def sample_diff(particles, delta, old_yaw, alphas, rng, noise, out, corrected=False):
    """diff / diff-corrected: move every particle by a noisy odometry increment.

    particles: (N, 3) input poses; out: (N, 3) output (may be ``particles``);
    noise: (N, 3) float64 scratch filled with standard normals; rng: numpy Generator.
    Returns out, yaw wrapped to [-pi, pi).
    """
    (rot1, trans, rot2), sd = diff_noise_std(delta, old_yaw, alphas, corrected)
    rng.standard_normal(out=noise)
    noise *= sd  # column k scaled by sd[k]
    # rot1^ and rot2^ as amcl: angle_diff(rot, N(sd)) -> rot - N; wrapping is applied to
    # the final heading below (the wrap of the components does not change cos/sin).
    rot1_hat = rot1 - noise[:, 0]
    trans_hat = trans - noise[:, 1]
    heading = particles[:, 2] + rot1_hat
    yaw_new = heading + (rot2 - noise[:, 2])
    out[:, 0] = particles[:, 0] + trans_hat * np.cos(heading)
    out[:, 1] = particles[:, 1] + trans_hat * np.sin(heading)
    out[:, 2] = wrap_angle(yaw_new)
    return out


def sample_omni(particles, delta, old_yaw, alphas, rng, noise, out, corrected=False):
    """omni / omni-corrected: move every particle by a noisy holonomic increment.

    Same arguments as sample_diff; alphas uses all five (a5: strafe noise).
    """
    (trans, rot), sd = omni_noise_std(delta, alphas, corrected)
    rng.standard_normal(out=noise)
    noise *= sd
    bearing = particles[:, 2] + float(angle_diff(np.arctan2(delta[1], delta[0]), old_yaw))
    trans_hat = trans + noise[:, 0]
    strafe_hat = noise[:, 2]
    cb, sb = np.cos(bearing), np.sin(bearing)
    yaw_new = particles[:, 2] + rot + noise[:, 1]
    out[:, 0] = particles[:, 0] + trans_hat * cb + strafe_hat * sb
    out[:, 1] = particles[:, 1] + trans_hat * sb - strafe_hat * cb
    out[:, 2] = wrap_angle(yaw_new)
    return out


def sample_motion(model_type, particles, delta, old_yaw, alphas, rng, noise=None, out=None):
    """Dispatch on amcl's odom_model_type; see sample_diff. Returns out.

    model_type: one of MODELS; delta: odom increment (dx, dy, dyaw) in the odom frame
    [m, m, rad]; old_yaw: odom heading at the last filter update [rad]; alphas:
    (odom_alpha1..5). noise / out: preallocated (N, 3) float64 buffers (allocated when
    None).
    """
    if model_type not in MODELS:
        raise ValueError(f"odom_model_type must be one of {', '.join(MODELS)}, got {model_type!r}")
    if noise is None:
        noise = np.empty(particles.shape, np.float64)
    if out is None:
        out = np.empty_like(particles)
    corrected = model_type.endswith("-corrected")
    if model_type.startswith("diff"):
        return sample_diff(particles, delta, old_yaw, alphas, rng, noise, out, corrected)
    return sample_omni(particles, delta, old_yaw, alphas, rng, noise, out, corrected)
