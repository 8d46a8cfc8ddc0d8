"""Motor drive and boundary conditions at the motor end (paper Sec. 2.3, Sec. 3.2).

* :class:`Motor` — the drive of the hook frame about e_z: a torque M(t) (constant, smoothly
  ramped on, or a piecewise-linear schedule), a speed clamp (imposed motor rotation rate, the
  torque is an output) or a torque–speed law (:class:`MotorLaw`); optional reversals
  (CCW ↔ CW) by a time schedule or a seeded telegraph process. The kernel solves the hook
  balance Eq. (12) for the torque of a speed clamp or a law exactly (see docs/motor.md).
* :class:`MotorLaw` — a torque–speed curve M(ω) of the bacterial flagellar motor, piecewise
  linear and non-increasing (E. coli: :meth:`MotorLaw.e_coli`; a user table).
* :class:`Boundary` — first bead anchored (``fixed``), attached to a load sphere of radius a
  moving along z with Stokes drag 6πηa (``sphere``); the hook as the paper's free universal
  joint (``free``), with bending stiffness k about the motor axis (``elastic``,
  E = k(1 − cos ϑ) ≈ kϑ²/2), or clamped along the motor axis (``clamped``, k → ∞); a free
  swimmer (``free``) with a body sphere centred on the first bead, or a whole cell: a rigid
  sphere or prolate spheroid free in 3D with the motor on its surface
  (:mod:`flagellum.hydro.body`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .errors import ParameterError
from .params import check_choice, check_range, check_real, positive


TWO_PI = 2 * math.pi
#: drive codes of the kernel (:func:`flagellum.rod.kernels.rhs`, iprm[I_DRIVE])
DRIVES = ("torque", "speed", "law")


def _table(name: str, values) -> tuple:
    try:
        out = tuple(check_real(name, float(v)) for v in values)
    except (TypeError, ValueError):
        raise ParameterError(name, values, "a sequence of finite numbers")
    return out


@dataclass(frozen=True)
class MotorLaw:
    """Torque–speed law M(ω) of a rotary motor [pN·µm] at motor speed ω [rad/s] relative to
    the body: linear interpolation between the nodes (``speeds``, ``torques``), held at the
    end values outside them (driven backwards: the first torque; overdriven: the last).

    ``speeds`` increase strictly from ≥ 0, ``torques`` are > 0 at the first node and do not
    increase (a law that rises with speed can have several operating points on one load line;
    a non-increasing law crossed by a load line with positive slope has exactly one).
    """

    speeds: tuple = ()
    torques: tuple = ()

    def __post_init__(self):
        s, m = _table("law speeds", self.speeds), _table("law torques", self.torques)
        if len(s) < 2 or len(s) != len(m):
            raise ParameterError("law", (self.speeds, self.torques),
                                 "at least two (speed, torque) nodes of equal count")
        if s[0] < 0 or any(b <= a for a, b in zip(s, s[1:])):
            raise ParameterError("law speeds", self.speeds, "strictly increasing values >= 0 [rad/s]")
        if m[0] <= 0 or any(b > a for a, b in zip(m, m[1:])) or m[-1] < 0:
            raise ParameterError("law torques", self.torques,
                                 "a stall torque > 0 and non-increasing values >= 0 [pN um]")
        if m[-1] == m[0]:
            raise ParameterError("law torques", self.torques,
                                 "a torque that falls with speed (a constant one is the torque drive)")
        object.__setattr__(self, "speeds", s)
        object.__setattr__(self, "torques", m)

    @classmethod
    def e_coli(cls, stall_torque: float = 1.3, knee_speed: float = TWO_PI * 170.0,
               zero_load_speed: float = TWO_PI * 300.0, knee_torque: float | None = None) -> "MotorLaw":
        """The E. coli flagellar motor near room temperature: torque ≈ the stall torque up to
        the knee, then falling linearly to zero at the zero-load speed. Defaults: stall torque
        1.3 pN·µm (≈ 1300 pN·nm, Berg, Annu. Rev. Biochem. 72, 19 (2003)), knee 170 Hz and
        zero-load speed 300 Hz (Chen & Berg, Biophys. J. 78, 1036 (2000), 22.7 °C); speeds in
        rad/s. ``knee_torque`` (default: the stall torque) gives the plateau a slope."""
        m0 = positive("stall_torque", stall_torque, 1e3)
        mk = m0 if knee_torque is None else check_range("knee_torque", knee_torque, 0.0, m0)
        wk = positive("knee_speed", knee_speed, 1e7)
        w0 = check_range("zero_load_speed", zero_load_speed, wk, 1e7)
        return cls((0.0, wk, w0), (m0, mk, 0.0))

    @classmethod
    def from_file(cls, path) -> "MotorLaw":
        """A table of (speed [rad/s], torque [pN·µm]) rows: a two-column CSV (``#`` comments
        and a non-numeric header line allowed) or a TOML file with arrays ``speeds`` and
        ``torques``."""
        from pathlib import Path

        from .io import read_text

        p = Path(path)
        text = read_text(path, "motor_law")  # (a FIFO, a device or a binary file: refused)
        if p.suffix.lower() == ".toml":
            import tomllib

            try:
                d = tomllib.loads(text)
                return cls(tuple(d["speeds"]), tuple(d["torques"]))
            except (tomllib.TOMLDecodeError, KeyError, TypeError) as e:
                raise ParameterError("motor_law", str(path), f"TOML with arrays speeds and torques ({e})")
        rows = []
        for line in text.splitlines():
            line = line.split("#", 1)[0].strip()
            if not line:
                continue
            parts = [x for x in line.replace(",", " ").replace(";", " ").split() if x]
            try:
                rows.append(tuple(float(x) for x in parts))
            except ValueError:
                if rows:  # only a first line may be a header
                    raise ParameterError("motor_law", str(path), f"two numeric columns (line {line!r})")
                continue
            if len(rows[-1]) != 2:
                raise ParameterError("motor_law", str(path), f"two columns speed, torque (line {line!r})")
        if not rows:
            raise ParameterError("motor_law", str(path), "a table of speed, torque rows")
        s, m = zip(*rows)
        return cls(s, m)

    def __call__(self, speed):
        return np.interp(speed, self.speeds, self.torques)

    @property
    def stall_torque(self) -> float:
        return self.torques[0]

    def operating_point(self, omega_per_torque: float) -> tuple[float, float]:
        """(torque, speed) where the law meets the load line ω = M · ``omega_per_torque``
        (a rigid load; :func:`flagellum.hydro.rft.pinned_omega_per_torque` for the paper's
        anchored filament): the same exact piecewise-linear solve as the kernel's."""
        b = positive("omega_per_torque", omega_per_torque)
        s, m = self.speeds, self.torques
        for k, (sk, mk) in enumerate(zip(s, m)):
            if sk / b - mk >= 0:  # load line at or above the law at node k
                if k == 0:
                    return mk, mk * b
                sl = (mk - m[k - 1]) / (sk - s[k - 1])
                u = (m[k - 1] - sl * s[k - 1]) / (1 / b - sl)
                return u / b, u
        return m[-1], m[-1] * b


def _law(value) -> MotorLaw | None:
    if value is None or isinstance(value, MotorLaw):
        return value
    if isinstance(value, dict):
        return MotorLaw(tuple(value.get("speeds", ())), tuple(value.get("torques", ())))
    raise ParameterError("law", value, "a MotorLaw")


@dataclass(frozen=True)
class Motor:
    """Drive of the hook frame about +e_z (paper Sec. 2.3; M > 0: the filament pushes, Sec. 3.1.1).

    ``drive``:

    * ``"torque"`` — motor torque M(t) [pN·µm]: ``torque``; ``ramp_time`` > 0 ramps it on as
      M (1 − cos(π t/T))/2 for t < T, which avoids the violent start of an abrupt switch-on;
      ``schedule`` = ((t0, M0), (t1, M1), …) replaces it by linear interpolation (held
      constant outside).
    * ``"speed"`` — speed clamp: the motor turns at ``speed`` [rad/s] relative to the body
      (ramped on like the torque); the torque it takes is an output.
    * ``"law"`` — torque–speed law ``law`` (:class:`MotorLaw`) at the motor speed relative to
      the body; a reversed motor follows ``cw_law`` (default: the mirror image of ``law``).

    Reversals (CCW ↔ CW; CCW is the given drive, CW its mirror: −M, −ω, or the CW branch of
    the law): ``reversals`` = (t1, t2, …) switching times [s], or ``reversal_rates`` =
    (k_ccw→cw, k_cw→ccw) [1/s], a telegraph process whose switching times follow from
    ``reversal_seed`` alone (the same times for every run and resume with that seed).
    """

    torque: float = 1.0
    ramp_time: float = 0.0
    schedule: tuple | None = None
    drive: str = "torque"
    speed: float = 0.0
    law: MotorLaw | None = None
    cw_law: MotorLaw | None = None
    reversals: tuple | None = None
    reversal_rates: tuple | None = None
    reversal_seed: int = 0

    def __post_init__(self):
        object.__setattr__(self, "torque", check_range("torque", self.torque, -1e3, 1e3, lo_open=False))
        object.__setattr__(self, "ramp_time", check_range("ramp_time", self.ramp_time, 0.0, 1e6, lo_open=False))
        if self.schedule is not None:
            try:
                sched = tuple((check_real("schedule time", float(t)), check_real("schedule torque", float(m)))
                              for t, m in self.schedule)
            except (TypeError, ValueError):
                raise ParameterError("schedule", self.schedule, "a sequence of (time, torque) pairs")
            if len(sched) < 1 or any(b[0] <= a[0] for a, b in zip(sched, sched[1:])):
                raise ParameterError("schedule", self.schedule, "(time, torque) pairs with increasing times")
            object.__setattr__(self, "schedule", sched)
        check_choice("drive", self.drive, DRIVES)
        object.__setattr__(self, "speed", check_range("speed", self.speed, -1e7, 1e7))
        object.__setattr__(self, "law", _law(self.law))
        object.__setattr__(self, "cw_law", _law(self.cw_law))
        if self.drive == "speed" and self.speed == 0:
            raise ParameterError("speed", self.speed, "!= 0 [rad/s] with drive = 'speed' "
                                 "(a stalled motor: drive = 'torque' at the stall torque)")
        if self.drive == "law" and self.law is None:
            raise ParameterError("law", None, "given (a MotorLaw) with drive = 'law'")
        if self.drive != "law" and (self.law is not None or self.cw_law is not None):
            raise ParameterError("law", self.law, "only with drive = 'law'")
        if self.drive == "law" and self.ramp_time:
            raise ParameterError("ramp_time", self.ramp_time, "0 with drive = 'law'")
        if self.drive != "torque" and self.schedule is not None:
            raise ParameterError("schedule", self.schedule, "only with drive = 'torque'")
        if self.reversals is not None and self.reversal_rates is not None:
            raise ParameterError("reversals", self.reversals, "not together with reversal_rates")
        if self.reversals is not None:
            ts = _table("reversals", self.reversals)
            if any(b <= a for a, b in zip(ts, ts[1:])):
                raise ParameterError("reversals", self.reversals, "strictly increasing switching times [s]")
            object.__setattr__(self, "reversals", ts)
        if self.reversal_rates is not None:
            rates = _table("reversal_rates", self.reversal_rates)
            if len(rates) != 2 or min(rates) <= 0:
                raise ParameterError("reversal_rates", self.reversal_rates,
                                     "two rates > 0 [1/s]: (CCW -> CW, CW -> CCW)")
            object.__setattr__(self, "reversal_rates", rates)
        seed = self.reversal_seed
        if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
            raise ParameterError("reversal_seed", seed, "a non-negative integer")
        object.__setattr__(self, "reversal_seed", int(seed))
        object.__setattr__(self, "_switches", [])  # telegraph switching times drawn so far

    @classmethod
    def from_flags(cls, torque: float | None = None, motor_speed: float | None = None,
                   motor_law=None, **reversals) -> "Motor":
        """The drive of the command-line flags and sweep values (one rule for every command):
        at most one of ``torque``, ``motor_speed`` (a speed clamp) and ``motor_law``
        (``"e-coli"``, a :class:`MotorLaw` or a table file) given, default the torque 1;
        ``reversals`` the further fields (ramp_time, reversals, reversal_rates, reversal_seed)."""
        given = [f"--{n}" for n, v in (("torque", torque), ("motor-speed", motor_speed),
                                        ("motor-law", motor_law)) if v is not None]
        if len(given) > 1:
            raise ParameterError("drive", " ".join(given), "one of --torque, --motor-speed, --motor-law")
        if motor_speed is not None:
            return cls(drive="speed", speed=motor_speed, **reversals)
        if motor_law is not None:
            law = motor_law if isinstance(motor_law, MotorLaw) else (
                MotorLaw.e_coli() if motor_law == "e-coli" else MotorLaw.from_file(motor_law))
            return cls(drive="law", law=law, **reversals)
        return cls(1.0 if torque is None else torque, **reversals)

    # -- time dependence -------------------------------------------------------------
    def _ramp(self, t: float) -> float:
        if self.ramp_time > 0 and t < self.ramp_time:
            return 0.5 * (1 - math.cos(math.pi * t / self.ramp_time))
        return 1.0

    def switching_times(self, t_end: float) -> tuple:
        """Reversal times up to ``t_end`` [s] (scheduled, or the telegraph process's: drawn
        in order from ``reversal_seed``, so they do not depend on ``t_end`` or on resumes)."""
        if self.reversals is not None:
            return tuple(t for t in self.reversals if t <= t_end)
        if self.reversal_rates is None:
            return ()
        sw = self._switches
        if not sw or sw[-1] <= t_end:
            rng = np.random.default_rng(self.reversal_seed)  # redraw the whole sequence: cheap
            sw.clear()
            t = 0.0
            while t <= t_end:
                if len(sw) > 10_000_000:
                    raise ParameterError("reversal_rates", self.reversal_rates,
                                         "rates giving fewer than 1e7 reversals in the run")
                t += rng.exponential(1.0 / self.reversal_rates[len(sw) % 2])
                sw.append(t)
            sw.extend(t + rng.exponential(1.0 / self.reversal_rates[len(sw) % 2]) for _ in range(64))
        return tuple(s for s in sw if s <= t_end)

    def direction(self, t: float) -> float:
        """+1 (CCW, the given drive) or −1 (CW) at time t."""
        if self.reversals is None and self.reversal_rates is None:
            return 1.0
        if self.reversals is not None:
            k = int(np.searchsorted(self.reversals, t, side="right"))
        else:
            self.switching_times(t)
            k = int(np.searchsorted(self._switches, t, side="right"))
        return -1.0 if k % 2 else 1.0

    def __call__(self, t: float) -> float:
        """The drive value the kernel reads (prm[P_TORQUE]): the torque [pN·µm] of the torque
        drive, the clamped speed [rad/s] of the speed clamp, the direction ±1 of a law."""
        d = self.direction(t)
        if self.drive == "speed":
            return d * self.speed * self._ramp(t)
        if self.drive == "law":
            return d
        if self.schedule is not None:
            ts, ms = zip(*self.schedule)
            m = float(np.interp(t, ts, ms))
        elif self.ramp_time > 0 and t < self.ramp_time:
            m = self.torque * 0.5 * (1 - math.cos(math.pi * t / self.ramp_time))
        else:
            m = self.torque
        return m if d == 1.0 else -m

    @property
    def final_torque(self) -> float:
        """The torque drive's torque at the end of its schedule (the given torque otherwise)."""
        return self.schedule[-1][1] if self.schedule is not None else self.torque

    def expected_torque(self, omega_per_torque: float) -> float:
        """The torque expected at steady state (before reversals) for a rigid load line
        ω = M · ``omega_per_torque``: the torque drive's final torque, the speed clamp's
        ω/omega_per_torque, the law's operating point on that line."""
        if self.drive == "torque":
            return self.final_torque
        if self.drive == "speed":
            return self.speed / omega_per_torque
        return self.law.operating_point(omega_per_torque)[0]

    def law_table(self) -> tuple[np.ndarray, np.ndarray]:
        """(CCW, CW) branches as flat arrays [speeds…, torques…] for the kernel (empty for
        the torque and speed drives); the CW branch in its own sense (speeds and torques of
        the reversed motor counted positive)."""
        if self.drive != "law":
            return np.zeros(0), np.zeros(0)
        cw = self.cw_law or self.law
        return (np.array(self.law.speeds + self.law.torques), np.array(cw.speeds + cw.torques))


@dataclass(frozen=True)
class Boundary:
    """Boundary conditions at the motor end.

    ``anchor``: ``"fixed"`` (bead 0 held), ``"sphere"`` (a load sphere of ``sphere_radius``
    moving along e_z, paper Sec. 3.2) or ``"free"``: a force- and torque-free swimmer, either
    with a body sphere of ``sphere_radius`` centred on bead 0 (its motor axis stays e_z), or,
    with ``body_radius``, a whole cell: a rigid body free in 3D (a sphere, or a prolate
    spheroid of equatorial semi-axis ``body_radius`` [µm] and polar semi-axis
    ``body_aspect``·``body_radius``) with the motor on its surface at ``motor_offset`` [deg]
    (eccentric angle from the rear pole) and the motor axis along the local normal, turning
    with the body (:mod:`flagellum.hydro.body`).
    """

    anchor: str = "fixed"
    sphere_radius: float | None = None
    hook: str = "free"
    hook_stiffness: float = 0.0  #: k [pN·µm] for ``hook="elastic"``
    body_radius: float | None = None  #: cell body's (equatorial) radius a [µm]
    body_aspect: float = 1.0  #: cell body's polar/equatorial semi-axis ratio p ≥ 1
    motor_offset: float = 0.0  #: motor position on the cell body [deg from the rear pole]

    def __post_init__(self):
        check_choice("anchor", self.anchor, ("fixed", "sphere", "free"))
        check_choice("hook", self.hook, ("free", "elastic", "clamped"))
        if self.anchor == "fixed" and self.sphere_radius is not None:  # never silently unused
            raise ParameterError("sphere_radius", self.sphere_radius,
                                 "given only with anchor = 'sphere' or 'free' (anchor is 'fixed')")
        if self.body_radius is not None:
            if self.anchor != "free":
                raise ParameterError("body_radius", self.body_radius,
                                     f"given only with anchor = 'free' (anchor is {self.anchor!r})")
            if self.sphere_radius is not None:
                raise ParameterError("sphere_radius", self.sphere_radius, "not together with "
                                     "body_radius (a centred body sphere or a cell body, not both)")
            object.__setattr__(self, "body_radius", positive("body_radius", self.body_radius, 1e3))
        a = check_range("body_aspect", self.body_aspect, 1.0, 100.0, lo_open=False)
        b = check_range("motor_offset", self.motor_offset, 0.0, 180.0, lo_open=False)
        if self.body_radius is None and (a != 1.0 or b != 0.0):
            raise ParameterError("body_aspect" if a != 1.0 else "motor_offset",
                                 a if a != 1.0 else b, "given only with body_radius (a cell body)")
        object.__setattr__(self, "body_aspect", a)
        object.__setattr__(self, "motor_offset", b)
        if self.anchor == "sphere":
            if self.sphere_radius is None:
                raise ParameterError("sphere_radius", None, "given (a number > 0) with anchor = 'sphere'")
            object.__setattr__(self, "sphere_radius", positive("sphere_radius", self.sphere_radius, 1e6))
        if self.anchor == "free" and self.body_radius is None:  # centred body; 0: the filament alone
            a = 0.0 if self.sphere_radius is None else self.sphere_radius
            object.__setattr__(self, "sphere_radius", check_range("sphere_radius", a, 0.0, 1e6, lo_open=False))
        k = check_range("hook_stiffness", self.hook_stiffness, 0.0, 1e6, lo_open=False)
        if self.hook == "elastic" and k == 0:
            raise ParameterError("hook_stiffness", k, "> 0 with hook = 'elastic'")
        object.__setattr__(self, "hook_stiffness", k if self.hook == "elastic" else 0.0)

    def to_dict(self) -> dict:
        """The fields as a dict; without a cell body, its (default) fields are left out."""
        from dataclasses import asdict

        d = asdict(self)
        if not self.is_cell:
            for k in ("body_radius", "body_aspect", "motor_offset"):
                d.pop(k)
        return d

    @property
    def is_cell(self) -> bool:
        """A whole cell: a rigid body free in 3D with the motor on its surface."""
        return self.body_radius is not None

    @classmethod
    def from_flags(cls, anchor: str | None = None, sphere_radius: float | None = None,
                   hook: str | None = None, hook_stiffness: float | None = None,
                   body_radius: float | None = None, body_aspect: float | None = None,
                   motor_offset: float | None = None) -> "Boundary":
        """The boundary of the command-line flags and sweep values: an anchor not given is a
        free cell when ``body_radius`` is given, a load sphere when ``sphere_radius`` is given
        (else fixed); a hook not given is elastic when ``hook_stiffness`` k > 0 (else free).
        Given values are kept as they are, and a value that the given kind would not use (a
        radius with a fixed anchor, k > 0 with a free or clamped hook, a body aspect without
        a body) is a :class:`ParameterError`."""
        k = 0.0 if hook_stiffness is None else hook_stiffness
        if hook not in (None, "elastic") and k != 0:  # a flag never silently unused
            raise ParameterError("hook_stiffness", k, f"given only with hook = 'elastic' "
                                                      f"(hook is {hook!r})")
        if anchor is None:
            anchor = "free" if body_radius is not None else "fixed" if sphere_radius is None else "sphere"
        if hook is None:
            hook = "elastic" if k else "free"
        return cls(anchor=anchor, sphere_radius=sphere_radius, hook=hook, hook_stiffness=k,
                   body_radius=body_radius, body_aspect=1.0 if body_aspect is None else body_aspect,
                   motor_offset=0.0 if motor_offset is None else motor_offset)

    def sphere_drag(self, viscosity: float) -> float:
        """Stokes drag 6πηa of the load sphere or of a free swimmer's centred body
        [pN·s/µm] (0 for a cell body: its resistance is :mod:`flagellum.hydro.body`'s)."""
        return 6 * math.pi * viscosity * self.sphere_radius if self.anchor != "fixed" and not self.is_cell else 0.0

    def body_rotation_rate(self, torque: float, viscosity: float) -> float:
        """Counter-rotation of a free swimmer's centred body about the motor axis,
        −M/(8πηa³) [rad/s]: the motor's reaction torque; a body centred on the hook feels no
        other torque (NaN without one; a cell body's rate is an output of the run)."""
        if self.anchor != "free" or not self.sphere_radius:
            return math.nan
        return -torque / (8 * math.pi * viscosity * self.sphere_radius ** 3)
