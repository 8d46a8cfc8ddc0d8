"""Observables of a trajectory (paper Sec. 3.1–3.2).

* thrust F: force of the filament on its anchor along e_z (on the load sphere when attached),
* ω: motor speed, the mean rotation rate of the hook frame (slope of its accumulated
  material angle, robust to thermal noise and to sparse sampling),
* χ: precession rate of the filament as a whole about the motor axis (azimuthal rate of its
  centroid; zero when the centroid stays on the axis, as in the aligned state),
* r(t) = |r_N − r_0|, ⟨r⟩ and σ (Eqs. (14)–(15)), σ in units of σ0 = R/√2,
* block-averaged means with standard errors, and a steady-state test.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import NamedTuple

import numpy as np


def end_to_end(positions: np.ndarray) -> np.ndarray:
    """r(t) = |r_N − r_0| for positions of shape (n_t, n+1, 3)."""
    return np.linalg.norm(positions[:, -1] - positions[:, 0], axis=-1)


def unwrapped_rate(t: np.ndarray, angle: np.ndarray) -> float:
    """Least-squares slope of an unwrapped angle series."""
    if len(t) < 2:
        return math.nan
    return float(np.polyfit(t, np.unwrap(angle), 1)[0])


def precession_rate(t: np.ndarray, positions: np.ndarray, min_offset: float) -> tuple[float, float]:
    """(χ, mean centroid offset from the motor axis); χ = 0 if the offset < ``min_offset``."""
    c = positions.mean(axis=1)
    rho = np.hypot(c[:, 0], c[:, 1])
    if len(t) < 2 or rho.mean() < min_offset:
        return 0.0, float(rho.mean()) if len(rho) else math.nan
    return unwrapped_rate(t, np.arctan2(c[:, 1], c[:, 0])), float(rho.mean())


def _slope(t, x) -> float:
    return float(np.polyfit(t, x, 1)[0]) if len(t) > 1 else math.nan


def block_average(x: np.ndarray, n_blocks: int = 8) -> tuple[float, float]:
    """Mean and its standard error from ``n_blocks`` contiguous block means."""
    x = np.asarray(x, float)
    if len(x) == 0:
        return math.nan, math.nan
    if len(x) < 2 * n_blocks:
        return float(x.mean()), float(x.std(ddof=1) / math.sqrt(len(x))) if len(x) > 1 else math.nan
    blocks = np.array([b.mean() for b in np.array_split(x, n_blocks)])
    return float(x.mean()), float(blocks.std(ddof=1) / math.sqrt(n_blocks))


def is_steady(x: np.ndarray, rel_tol: float = 1e-3, abs_tol: float = 1e-6) -> bool:
    """Time averages settled: first and second half of the window agree within their errors."""
    x = np.asarray(x, float)
    if len(x) < 16:
        return False
    a, ea = block_average(x[: len(x) // 2], 4)
    b, eb = block_average(x[len(x) // 2:], 4)
    tol = max(rel_tol * max(abs(a), abs(b)), abs_tol, 3 * math.hypot(ea, eb))
    return abs(a - b) <= tol


@dataclass(frozen=True)
class Summary:
    """Time averages over the window [t_from, t_end] of a run."""

    thrust_mean: float
    thrust_std: float
    thrust_err: float
    omega_mean: float
    chi_mean: float
    end_to_end_mean: float
    end_to_end_std: float
    energy_final: float
    centroid_offset: float
    swimming_speed: float  #: mean velocity of bead 0 along e_z [µm/s] (0 when anchored)
    t_from: float
    t_end: float
    samples: int
    #: operating point of the motor: mean torque [pN·µm] and mean motor speed relative to the
    #: body [rad/s] (ω_hook·e_z minus the body's rate; the speed a motor law is evaluated at)
    torque_mean: float = math.nan
    motor_speed_mean: float = math.nan
    #: the body's motion (a cell body; else the anchor or the centred body sphere):
    #: net swimming speed |mean velocity of its centre| along the mean swimming direction
    #: [µm/s], its mean path speed (between records) [µm/s], its mean rotation rate about its
    #: own axis Ω·axis [rad/s], and the wobble angle: mean angle between its axis and the mean
    #: swimming direction [deg] (NaN when it does not move)
    body_velocity: float = math.nan
    body_speed: float = math.nan
    body_rotation_rate: float = math.nan
    wobble_angle_deg: float = math.nan
    #: the helical path of the body's centre (:func:`fit_helical_path`): radius [µm], pitch
    #: (advance per turn) [µm], period of one turn [s] and the unit axis (NaN when the body
    #: does not move or its path has no turn)
    path_radius: float = math.nan
    path_pitch: float = math.nan
    path_period: float = math.nan
    path_axis_x: float = math.nan
    path_axis_y: float = math.nan
    path_axis_z: float = math.nan

    def to_dict(self) -> dict:
        return asdict(self)


def summarize(t, thrust, motor_angle, positions, energy, helix_radius: float,
              t_from: float | None = None, torque=None, motor_speed=None, body=None) -> Summary:
    """Averages over t ≥ t_from (default: the last half of the run); ω is the slope of the
    unwrapped ``motor_angle`` (rotation rate about the local helix axis at the motor).
    ``torque`` and ``motor_speed`` (relative to the body) give the operating point;
    ``body`` = (centre (n_t, 3), axis (n_t, 3), angular velocity (n_t, 3)) its motion
    (:func:`body_motion`)."""
    t = np.asarray(t, float)
    if t_from is None:
        t_from = t[0] + 0.5 * (t[-1] - t[0])
    sel = t >= t_from - 1e-15
    if sel.sum() < 1:
        sel = np.zeros_like(t, bool)
        sel[-1] = True
    th = np.asarray(thrust)[sel]
    r = end_to_end(np.asarray(positions)[sel])
    m, err = block_average(th)
    rel = np.asarray(positions)[sel] - np.asarray(positions)[sel][:, :1]  # about the motor (bead 0)
    chi, rho = precession_rate(t[sel], rel, 0.25 * helix_radius)
    return Summary(thrust_mean=m, thrust_std=float(th.std()), thrust_err=err,
                   omega_mean=_slope(t[sel], np.asarray(motor_angle)[sel]), chi_mean=chi,
                   end_to_end_mean=float(r.mean()), end_to_end_std=float(r.std()),
                   energy_final=float(np.asarray(energy)[-1]), centroid_offset=rho,
                   swimming_speed=_slope(t[sel], np.asarray(positions)[sel][:, 0, 2]),
                   t_from=float(t_from), t_end=float(t[-1]), samples=int(sel.sum()),
                   torque_mean=_mean(torque, sel), motor_speed_mean=_mean(motor_speed, sel),
                   **(body_motion(t[sel], *(np.asarray(b, float)[sel] for b in body))
                      if body is not None else {}))


def body_motion(t, position, axis, angular_velocity) -> dict:
    """Swimming of a body over a window: ``body_velocity`` = |V̄| with V̄ the least-squares
    velocity of its centre (the net speed along the mean swimming direction V̄/|V̄|),
    ``body_speed`` = mean |Δx/Δt| between records (the speed along its helical path),
    ``body_rotation_rate`` = mean Ω·axis, ``wobble_angle_deg`` = mean angle between the axis
    and V̄/|V̄| (NaN when V̄ = 0), and the helix fitted to the path (``path_*``,
    :func:`fit_helical_path`)."""
    out = dict(body_velocity=math.nan, body_speed=math.nan, body_rotation_rate=math.nan,
               wobble_angle_deg=math.nan)
    if len(t) < 2 or not np.all(np.isfinite(position)):
        return out
    path = fit_helical_path(t, position)
    if path.radius > 0:
        out.update(path_radius=path.radius, path_pitch=path.pitch, path_period=path.period,
                   **{f"path_axis_{c}": float(path.axis[k]) for k, c in enumerate("xyz")})
    v = np.polyfit(t - t[0], position, 1)[0]
    speed = float(np.linalg.norm(v))
    steps = np.linalg.norm(np.diff(position, axis=0), axis=1) / np.diff(t)
    out.update(body_velocity=speed, body_speed=float(steps.mean()),
               body_rotation_rate=float(np.mean(np.einsum("ij,ij->i", angular_velocity, axis))))
    if speed > 1e-9:
        cos = np.clip(axis @ (v / speed), -1.0, 1.0)
        out["wobble_angle_deg"] = float(np.degrees(np.arccos(cos)).mean())
    return out


class HelicalPath(NamedTuple):
    """A path fitted by a circular helix x(t) = c + v t â + R (cos ωt e1 + sin ωt e2)
    (:func:`fit_helical_path`)."""

    radius: float  #: R [µm]
    pitch: float  #: axial advance per turn, |v|·period [µm]
    axis: np.ndarray  #: unit axis â, along the net motion
    period: float  #: 2π/ω [s]
    axial_speed: float  #: |v| [µm/s]
    handedness: int  #: +1 right-handed (counter-clockwise seen from the tip of â), −1 left, 0 none
    residual: float  #: rms distance of the path from the fitted helix [µm]


def _helix_lsq(t: np.ndarray, x: np.ndarray, omega: float):
    """Least-squares c, v, A, B of x ≈ c + v t + A cos ωt + B sin ωt and the residual sum."""
    basis = np.column_stack([np.ones_like(t), t, np.cos(omega * t), np.sin(omega * t)])
    coef, *_ = np.linalg.lstsq(basis, x, rcond=None)
    return coef, float(np.sum((basis @ coef - x) ** 2))


def fit_helical_path(t, position) -> HelicalPath:
    """Fit the path ``position`` (n, 3) at times ``t`` by a circular helix.

    The model x(t) = c + v t + A cos ωt + B sin ωt is linear for a given ω; ω starts at
    the peak of the power spectrum of the detrended path (zero-padded, resampled onto an
    even grid) and is refined by minimizing the residual within one frequency bin. The axis
    is v/|v|; the radius the rms of A and B across it, R = √((|A⊥|² + |B⊥|²)/2); the pitch
    |v|·2π/ω. A straight path (no oscillation above 1e-12 of its length) has R = 0 and NaN
    period and pitch. Needs at least 8 records spanning more than one turn for a period.
    """
    from scipy.optimize import minimize_scalar

    t = np.asarray(t, float)
    x = np.asarray(position, float)
    nan = math.nan
    if len(t) < 8 or x.shape != (len(t), 3) or not np.all(np.isfinite(x)):
        return HelicalPath(nan, nan, np.full(3, nan), nan, nan, 0, nan)
    t = t - t[0]
    span = t[-1]
    line = np.polyfit(t, x, 1)
    v = line[0]
    speed = float(np.linalg.norm(v))
    axis = v / speed if speed > 0 else np.full(3, nan)
    rest = x - (line[1] + np.outer(t, v))
    scale = max(float(np.abs(x - x[0]).max()), 1e-300)
    if float(np.abs(rest).max()) <= 1e-12 * scale:
        return HelicalPath(0.0, nan, axis, nan, speed, 0, float(np.sqrt(np.mean(np.sum(rest ** 2, 1)))))
    grid = np.linspace(0.0, span, len(t))
    even = np.column_stack([np.interp(grid, t, rest[:, k]) for k in range(3)])
    pad = 8 * len(grid)
    power = np.sum(np.abs(np.fft.rfft(even - even.mean(0), n=pad, axis=0)) ** 2, axis=1)
    k = 1 + int(np.argmax(power[1:]))
    dw = 2 * math.pi / (pad * (grid[1] - grid[0]))
    w0 = k * dw
    res = minimize_scalar(lambda w: _helix_lsq(t, x, w)[1], bounds=(max(w0 - dw, 0.5 * dw), w0 + dw),
                          method="bounded", options={"xatol": 1e-12 * w0})
    omega = float(res.x)
    coef, ss = _helix_lsq(t, x, omega)
    v, a, b = coef[1], coef[2], coef[3]
    speed = float(np.linalg.norm(v))
    axis = v / speed if speed > 1e-300 else np.cross(a, b) / np.linalg.norm(np.cross(a, b))
    a_p, b_p = a - (a @ axis) * axis, b - (b @ axis) * axis
    radius = math.sqrt(0.5 * (a_p @ a_p + b_p @ b_p))
    period = 2 * math.pi / omega
    hand = int(np.sign(np.cross(a_p, b_p) @ axis))
    return HelicalPath(radius, speed * period, axis, period, speed, hand, math.sqrt(ss / len(t)))


def _mean(x, sel) -> float:
    return math.nan if x is None else float(np.mean(np.asarray(x, float)[sel]))
