"""Extended Kalman filter with robot_localization's omnidirectional motion model.

Moore & Stouch 2014, "A Generalized Extended Kalman Filter Implementation for the Robot
Operating System" (IAS-13), as robot_localization's ekf_localization_node documents it.
No rospy: arrays in, arrays out; nodes/ekf_localization_node is the ROS adapter.

State (robot_localization's 15 indices, kept whole so its 15-bool `_config` vectors
index it directly):
    0 x, 1 y, 2 z [m]               position in the world frame (odom)
    3 roll, 4 pitch, 5 yaw [rad]    orientation in the world frame (fixed axes X-Y-Z)
    6 vx, 7 vy, 8 vz [m/s]          linear velocity in the body frame (base_link)
    9 vroll, 10 vpitch, 11 vyaw [rad/s]  angular velocity in the body frame
    12 ax, 13 ay, 14 az [m/s^2]     linear acceleration in the body frame

Prediction over dt [s] (constant acceleration, constant body rates):
    p      += R(roll, pitch, yaw) (v dt + a dt^2 / 2)
    angles += E(roll, pitch) w dt     (E: body rates -> Euler-angle rates)
    v      += a dt
    P       = J P J^T + Q dt          (J: the Jacobian of the step; Q: process_noise_covariance)
Correction with a measurement of the state indices its mask selects (H: those rows of
the identity), innovation angles wrapped to [-pi, pi):
    S = H P H^T + R;   rejected when innovation^T S^-1 innovation >= threshold^2
    K = P H^T S^-1;    x += K innovation;   P = (I - K H) P (I - K H)^T + K R K^T  (Joseph)
two_d_mode keeps z, roll, pitch and their rates (and az) at 0 with a tiny variance, and a
measurement never updates them. The first accepted measurement sets the state it measures
(and that block of P) instead of correcting it, as robot_localization does.
"""
import math
from dataclasses import dataclass, field

import numpy as np

STATE_SIZE = 15
X, Y, Z, ROLL, PITCH, YAW, VX, VY, VZ, VROLL, VPITCH, VYAW, AX, AY, AZ = range(STATE_SIZE)
STATE_NAMES = ("x", "y", "z", "roll", "pitch", "yaw", "vx", "vy", "vz",
               "vroll", "vpitch", "vyaw", "ax", "ay", "az")
ANGLES = (ROLL, PITCH, YAW)
# the variables two_d_mode holds at 0 (robot_localization's 2D mode)
TWO_D_FIXED = (Z, ROLL, PITCH, VZ, VROLL, VPITCH, AZ)
MIN_VARIANCE = 1e-9        # a measurement variance below this is raised to it (a zero would make S singular)
TWO_D_VARIANCE = 1e-9      # variance the 2D-fixed variables keep
MAX_DT = 3600.0            # [s] a longer step is taken for a clock jump and not predicted over
TWO_PI = 2.0 * math.pi
IDENTITY = np.eye(STATE_SIZE)


def wrap(a):
    """Angle(s) [rad] into [-pi, pi)."""
    return (np.asarray(a, dtype=np.float64) + math.pi) % (2.0 * math.pi) - math.pi


def rotation(roll, pitch, yaw):
    """3x3 rotation R = Rz(yaw) Ry(pitch) Rx(roll): body vector -> world vector."""
    cr, sr = math.cos(roll), math.sin(roll)
    cp, sp = math.cos(pitch), math.sin(pitch)
    cy, sy = math.cos(yaw), math.sin(yaw)
    return np.array([[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
                     [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
                     [-sp, cp * sr, cp * cr]])


def rotation_derivatives(roll, pitch, yaw):
    """dR/droll, dR/dpitch, dR/dyaw of rotation()."""
    cr, sr = math.cos(roll), math.sin(roll)
    cp, sp = math.cos(pitch), math.sin(pitch)
    cy, sy = math.cos(yaw), math.sin(yaw)
    rz = np.array([[cy, -sy, 0.0], [sy, cy, 0.0], [0.0, 0.0, 1.0]])
    ry = np.array([[cp, 0.0, sp], [0.0, 1.0, 0.0], [-sp, 0.0, cp]])
    rx = np.array([[1.0, 0.0, 0.0], [0.0, cr, -sr], [0.0, sr, cr]])
    drz = np.array([[-sy, -cy, 0.0], [cy, -sy, 0.0], [0.0, 0.0, 0.0]])
    dry = np.array([[-sp, 0.0, cp], [0.0, 0.0, 0.0], [-cp, 0.0, -sp]])
    drx = np.array([[0.0, 0.0, 0.0], [0.0, -sr, -cr], [0.0, cr, -sr]])
    return rz @ ry @ drx, rz @ dry @ rx, drz @ ry @ rx


def euler_rate_matrix(roll, pitch):
    """E with (roll, pitch, yaw) rates = E (vroll, vpitch, vyaw) body rates, and its
    derivatives dE/droll, dE/dpitch. Singular at pitch = +-pi/2 (gimbal lock)."""
    cr, sr = math.cos(roll), math.sin(roll)
    cp, sp = math.cos(pitch), math.sin(pitch)
    tp, sec = sp / cp, 1.0 / cp
    e = np.array([[1.0, sr * tp, cr * tp], [0.0, cr, -sr], [0.0, sr * sec, cr * sec]])
    de_dr = np.array([[0.0, cr * tp, -sr * tp], [0.0, -sr, -cr], [0.0, cr * sec, -sr * sec]])
    de_dp = np.array([[0.0, sr * sec * sec, cr * sec * sec], [0.0, 0.0, 0.0],
                      [0.0, sr * sec * tp, cr * sec * tp]])
    return e, de_dr, de_dp


def predict_state(x, dt):
    """The motion model: state x (15,) moved on by dt [s]; a new array."""
    r, p, y = x[ROLL], x[PITCH], x[YAW]
    v, w, a = x[VX:VZ + 1], x[VROLL:VYAW + 1], x[AX:AZ + 1]
    out = x.copy()
    out[X:Z + 1] += rotation(r, p, y) @ (v * dt + 0.5 * a * dt * dt)
    out[ROLL:YAW + 1] = wrap(x[ROLL:YAW + 1] + euler_rate_matrix(r, p)[0] @ w * dt)
    out[VX:VZ + 1] += a * dt
    return out


def predict_jacobian(x, dt):
    """d predict_state(x, dt) / dx, (15, 15)."""
    r, p, y = x[ROLL], x[PITCH], x[YAW]
    v, w, a = x[VX:VZ + 1], x[VROLL:VYAW + 1], x[AX:AZ + 1]
    rot = rotation(r, p, y)
    e, de_dr, de_dp = euler_rate_matrix(r, p)
    disp = v * dt + 0.5 * a * dt * dt           # body-frame displacement [m]
    j = np.eye(STATE_SIZE)
    j[X:Z + 1, VX:VZ + 1] = rot * dt
    j[X:Z + 1, AX:AZ + 1] = rot * (0.5 * dt * dt)
    for col, d in zip(ANGLES, rotation_derivatives(r, p, y)):
        j[X:Z + 1, col] = d @ disp
    j[ROLL:YAW + 1, VROLL:VYAW + 1] = e * dt
    j[ROLL:YAW + 1, ROLL] += de_dr @ w * dt
    j[ROLL:YAW + 1, PITCH] += de_dp @ w * dt
    j[VX:VZ + 1, AX:AZ + 1] = np.eye(3) * dt
    return j


def predict_step(x, dt, j):
    """predict_state(x, dt) and predict_jacobian(x, dt) at once, the fast way: scalar
    arithmetic, the Jacobian written into j (a (15, 15) identity on entry, reset here).
    predict_state / predict_jacobian are its slow, obvious reference (the tests' oracle).
    Returns the new state."""
    (px, py, pz, r, p, y, vx, vy, vz, wr, wp, wy, ax, ay, az) = x.tolist()
    cr, sr, cp, sp, cy, sy = math.cos(r), math.sin(r), math.cos(p), math.sin(p), math.cos(y), math.sin(y)
    half = 0.5 * dt * dt
    dx, dy, dz = vx * dt + ax * half, vy * dt + ay * half, vz * dt + az * half   # body displacement [m]
    r00, r01, r02 = cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr
    r10, r11, r12 = sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr
    r20, r21, r22 = -sp, cp * sr, cp * cr
    tp, sec = sp / cp, 1.0 / cp
    out = x.copy()
    out[0] = px + r00 * dx + r01 * dy + r02 * dz
    out[1] = py + r10 * dx + r11 * dy + r12 * dz
    out[2] = pz + r20 * dx + r21 * dy + r22 * dz
    droll = (wr + sr * tp * wp + cr * tp * wy) * dt
    dpitch = (cr * wp - sr * wy) * dt
    dyaw = (sr * sec * wp + cr * sec * wy) * dt
    out[3] = (r + droll + math.pi) % TWO_PI - math.pi
    out[4] = (p + dpitch + math.pi) % TWO_PI - math.pi
    out[5] = (y + dyaw + math.pi) % TWO_PI - math.pi
    out[6], out[7], out[8] = vx + ax * dt, vy + ay * dt, vz + az * dt
    j[...] = IDENTITY
    j[0:3, 6:9] = ((r00 * dt, r01 * dt, r02 * dt), (r10 * dt, r11 * dt, r12 * dt), (r20 * dt, r21 * dt, r22 * dt))
    j[0:3, 12:15] = ((r00 * half, r01 * half, r02 * half), (r10 * half, r11 * half, r12 * half),
                     (r20 * half, r21 * half, r22 * half))
    # d position / d (roll, pitch, yaw): dR/d angle times the displacement
    j[0, 3] = (cy * sp * cr + sy * sr) * dy + (-cy * sp * sr + sy * cr) * dz
    j[1, 3] = (sy * sp * cr - cy * sr) * dy + (-sy * sp * sr - cy * cr) * dz
    j[2, 3] = cp * cr * dy - cp * sr * dz
    j[0, 4] = -cy * sp * dx + cy * cp * sr * dy + cy * cp * cr * dz
    j[1, 4] = -sy * sp * dx + sy * cp * sr * dy + sy * cp * cr * dz
    j[2, 4] = -cp * dx - sp * sr * dy - sp * cr * dz
    j[0, 5] = -r10 * dx - r11 * dy - r12 * dz
    j[1, 5] = r00 * dx + r01 * dy + r02 * dz
    j[3:6, 9:12] = ((dt, sr * tp * dt, cr * tp * dt), (0.0, cr * dt, -sr * dt), (0.0, sr * sec * dt, cr * sec * dt))
    j[3, 3] += (cr * tp * wp - sr * tp * wy) * dt
    j[4, 3] = (-sr * wp - cr * wy) * dt
    j[5, 3] = (cr * sec * wp - sr * sec * wy) * dt
    j[3, 4] = (sr * sec * sec * wp + cr * sec * sec * wy) * dt
    j[5, 4] = (sr * sec * tp * wp + cr * sec * tp * wy) * dt
    j[6, 12] = j[7, 13] = j[8, 14] = dt
    return out


@dataclass
class Measurement:
    """A measurement of some state variables.

    stamp [s]; z (15,) values (only the masked ones are read); cov (15, 15) their
    covariance; mask (15,) bool: which state variables it measures; threshold: the
    Mahalanobis distance at or beyond which it is rejected (inf: never); source: a name
    for messages (the topic)."""
    stamp: float
    z: np.ndarray
    cov: np.ndarray
    mask: np.ndarray
    threshold: float = math.inf
    source: str = ""


@dataclass
class Outcome:
    """What correct() did: accepted, and why not when not; the squared Mahalanobis
    distance of the innovation (None when not computed)."""
    accepted: bool
    reason: str = ""
    mahalanobis_sq: float = None
    indices: tuple = field(default_factory=tuple)


class Ekf:
    """The filter: state (15,), covariance P (15, 15), time [s] of the state.

    process_noise: Q (15, 15) per second (process_noise_covariance); initial_covariance:
    P before the first measurement (initial_estimate_covariance); two_d_mode: see the
    module docstring."""

    def __init__(self, process_noise, initial_covariance, two_d_mode=False):
        self.q = np.array(process_noise, dtype=np.float64).reshape(STATE_SIZE, STATE_SIZE)
        self.p0 = np.array(initial_covariance, dtype=np.float64).reshape(STATE_SIZE, STATE_SIZE)
        self.two_d_mode = bool(two_d_mode)
        self._j = np.eye(STATE_SIZE)          # the step's Jacobian, reused
        free = np.ones(STATE_SIZE, dtype=bool)
        if self.two_d_mode:
            free[list(TWO_D_FIXED)] = False
        self._free = free                     # the variables a measurement may update
        self._fixed = np.flatnonzero(~free)
        self._fixed_diag = np.zeros((STATE_SIZE, STATE_SIZE))
        self._fixed_diag[self._fixed, self._fixed] = TWO_D_VARIANCE
        self._free_2d = np.outer(free, free)
        self._selections = {}                 # measured indices -> _Selection, built once each
        self.reset()

    def reset(self, state=None, covariance=None, stamp=None):
        """Back to the initial state (zeros) and P, or to the given ones; stamp [s] or None
        (then the next measurement initializes the filter)."""
        self.x = np.zeros(STATE_SIZE) if state is None else np.array(state, dtype=np.float64)
        self.P = self.p0.copy() if covariance is None else np.array(covariance, dtype=np.float64)
        self.time = stamp
        self.initialized = stamp is not None
        self._force_two_d()

    def predict(self, dt):
        """Moves the state on by dt [s] (dt <= 0: nothing)."""
        if not dt > 0.0:
            return
        j = self._j
        x = predict_step(self.x, dt, j)
        p = j @ self.P @ j.T
        p += self.q * dt
        if math.isfinite(x.sum() + p.sum()):   # never let a NaN in
            self.x, self.P = x, _symmetric(p)
        self._force_two_d()

    def predict_to(self, stamp):
        """Predicts up to stamp [s] if that is later than the state's time."""
        if self.time is None:
            return
        dt = stamp - self.time
        if dt > MAX_DT:
            self.time = stamp     # a clock jump: no prediction over an hour
            return
        if dt > 0.0:
            self.predict(dt)
            self.time = stamp

    def predicted(self, stamp):
        """(x, P, stamp): the state predicted to stamp [s], the filter left as it is."""
        keep = (self.x, self.P, self.time)
        try:
            self.predict_to(stamp)
            return self.x, self.P, self.time
        finally:
            self.x, self.P, self.time = keep

    def process(self, m: Measurement) -> Outcome:
        """Predicts to the measurement's stamp and corrects with it; the first one
        initializes the filter. A stamp older than the state's time is corrected without
        prediction (robot_localization without smooth_lagged_data does the same)."""
        idx = self.usable_indices(m)
        if not idx:
            return Outcome(False, "nothing to fuse (masked variables absent or not finite)")
        if not self.initialized:
            ii = np.ix_(idx, idx)
            self.x[idx] = m.z[idx]
            self.x[list(ANGLES)] = wrap(self.x[list(ANGLES)])
            self.P[ii] = _measurement_covariance(m.cov[ii])
            self.time = m.stamp
            self.initialized = True
            self._force_two_d()
            return Outcome(True, "initialized", None, tuple(idx))
        self.predict_to(m.stamp)
        return self.correct(m, idx)

    def usable_indices(self, m: Measurement):
        """The state indices m measures whose values and variances are finite, without the
        2D-fixed ones in two_d_mode."""
        mask = m.mask & self._free & np.isfinite(m.z) & np.isfinite(np.diagonal(m.cov))
        return np.flatnonzero(mask).tolist()

    def correct(self, m: Measurement, idx=None) -> Outcome:
        """The EKF correction with m's masked variables (no prediction). The fast form of
        correction_reference (the tests' oracle): H is never built, P's Joseph update is
        written with the n measured columns of P only (see _joseph)."""
        if idx is None:
            idx = self.usable_indices(m)
        if not idx:
            return Outcome(False, "nothing to fuse (masked variables absent or not finite)")
        key = tuple(idx)
        sel = self._selections.get(key)
        if sel is None:
            sel = self._selections[key] = _Selection(key)
        r = _measurement_covariance(m.cov[sel.block])
        if not math.isfinite(r.sum()):
            return Outcome(False, "covariance not finite", None, key)
        innovation = m.z[sel.index] - self.x[sel.index]
        for k in sel.angles:   # roll, pitch, yaw innovations wrapped
            innovation[k] = (innovation[k] + math.pi) % TWO_PI - math.pi
        ph = self.P[:, sel.index]                 # P H^T (15, n)
        s = ph[sel.index] + r                     # H P H^T + R
        s_inv = _inverse(s)
        if s_inv is None:
            return Outcome(False, "innovation covariance singular", None, key)
        d2 = float(innovation @ s_inv @ innovation)
        if not math.isfinite(d2):
            return Outcome(False, "innovation not finite", None, key)
        if d2 >= m.threshold * m.threshold:
            return Outcome(False, f"Mahalanobis distance {math.sqrt(d2):.3g} >= threshold {m.threshold:g}",
                           d2, key)
        k = ph @ s_inv                             # (15, n)
        x = self.x + k @ innovation
        x[3:6] = (x[3:6] + math.pi) % TWO_PI - math.pi
        p = _joseph(self.P, ph, k, r, sel.index)
        if not math.isfinite(x.sum() + p.sum()):
            return Outcome(False, "update not finite", d2, key)
        self.x, self.P = x, _symmetric(p)
        self._force_two_d()
        return Outcome(True, "", d2, key)

    def _force_two_d(self):
        if not self.two_d_mode:
            return
        self.x[self._fixed] = 0.0
        self.P *= self._free_2d          # rows and columns of the fixed variables to 0 ...
        self.P += self._fixed_diag       # ... and their variances to TWO_D_VARIANCE


class _Selection:
    """The index arrays of one set of measured state indices (a sensor's _config gives
    the same set message after message, so they are built once)."""

    def __init__(self, idx):
        self.index = np.array(idx, dtype=np.intp)
        self.block = np.ix_(self.index, self.index)
        self.angles = [k for k, i in enumerate(idx) if i in ANGLES]


def _inverse(s):
    """S^-1 of the (n, n) innovation covariance; None when singular. n = 1 (a gyro's yaw
    rate, most messages) without LAPACK."""
    if s.shape[0] == 1:
        v = s[0, 0]
        return None if v == 0.0 else np.array([[1.0 / v]])
    try:
        return np.linalg.inv(s)
    except np.linalg.LinAlgError:
        return None


def _joseph(p, ph, k, r, index):
    """(I - K H) P (I - K H)^T + K R K^T with H the rows `index` of the identity, from
    P H^T = ph (15, n) and K (15, n): (I - K H) P = P - K ph^T (P symmetric), and
    M (I - K H)^T = M - M[:, index] K^T; 15 x n products instead of 15 x 15 ones."""
    ap = p - k @ ph.T
    out = ap - ap[:, index] @ k.T
    out += (k @ r) @ k.T
    return out


def correction_reference(x, p, idx, z, cov, threshold=math.inf):
    """The EKF correction in its obvious matrix form, the oracle of Ekf.correct: H the
    measured rows of the identity, S = H P H^T + R, K = P H^T S^-1, x + K y (angles
    wrapped), P by Joseph's form. x (15,), p (15, 15), idx the measured indices, z (15,)
    and cov (15, 15) the measurement. Returns (x, P, d2) with d2 the squared Mahalanobis
    distance, or (None, None, d2) when rejected."""
    idx = list(idx)
    h = IDENTITY[idx, :]
    r = _measurement_covariance(cov[np.ix_(idx, idx)])
    y = h @ z - h @ x
    for k, i in enumerate(idx):
        if i in ANGLES:
            y[k] = float(wrap(y[k]))
    s = h @ p @ h.T + r
    s_inv = np.linalg.inv(s)
    d2 = float(y @ s_inv @ y)
    if d2 >= threshold * threshold:
        return None, None, d2
    k = p @ h.T @ s_inv
    x_new = x + k @ y
    x_new[3:6] = wrap(x_new[3:6])
    ikh = IDENTITY - k @ h
    return x_new, _symmetric(ikh @ p @ ikh.T + k @ r @ k.T), d2


def _measurement_covariance(r):
    """r with negative variances made positive and tiny ones raised to MIN_VARIANCE (as
    robot_localization does: a zero variance would make the innovation covariance
    singular)."""
    r = np.array(r, dtype=np.float64)
    d = np.abs(np.diagonal(r))
    np.fill_diagonal(r, np.maximum(d, MIN_VARIANCE))
    return _symmetric(r)


def _symmetric(p):
    return 0.5 * (p + p.T)
