"""Model parameters as immutable, validated dataclasses.

Units everywhere: µm, pN, s (so energies in pN·µm, viscosity in pN·s/µm²).

Three groups, as in Vogel & Stark (2012) Sec. 2.4:

* :class:`Filament` — geometry and elasticity of the helical filament (Eqs. (3)–(5)),
* :class:`Fluid` — viscosity, filament radius and thermal energy,
* :class:`Friction` — local resistive-force coefficients γ∥, γ⊥, γR (Eqs. (6)–(7)); either the
  paper's rounded values, Lighthill's formulas (App. A), or user-given values.

:class:`Params` bundles them and reads/writes TOML with the same names as the CLI flags.
"""

from __future__ import annotations

import math
import sys
try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib
from dataclasses import asdict, dataclass, field, fields
from numbers import Real
from pathlib import Path
from typing import Any

from .errors import ParameterError
from .paper import NORMAL_HELIX, PAPER

#: The paper's rounded friction coefficients (Sec. 2.4): γ∥, γ⊥ in pN·s/µm², γR in pN·s.
PAPER_FRICTION = tuple(PAPER[k].value for k in ("gamma_par", "gamma_perp", "gamma_rot"))
#: The physical range of each friction coefficient (given or from Lighthill's formulas):
#: far below the paper's values the relaxation times of the bond-scale modes shrink with the
#: friction, and the stiff integrator's steps with them, until a run makes no progress.
FRICTION_RANGE = {"gamma_par": (1e-6, 1e6), "gamma_perp": (1e-6, 1e6), "gamma_rot": (1e-10, 1e6)}
#: Most segments of a filament: the CVODE linear solver holds a dense (4N+7)² Jacobian
#: (0.5 GB at this size).
MAX_SEGMENTS = 2000


def check_real(name: str, value: Any, allowed: str = "a finite number") -> float:
    """Return ``value`` as float, or raise :class:`ParameterError` if it is not a finite real."""
    if isinstance(value, bool) or not isinstance(value, Real):
        raise ParameterError(name, value, allowed)
    try:
        value = float(value)
    except OverflowError:  # an integer beyond the float range (e.g. a TOML integer of 400 digits)
        raise ParameterError(name, f"an integer of {len(str(abs(value)))} digits", allowed) from None
    if not math.isfinite(value):
        raise ParameterError(name, value, allowed)
    if value != 0 and abs(value) < sys.float_info.min:  # subnormal: arithmetic 100× slower
        raise ParameterError(name, value, f"{allowed}, not subnormal (|x| ≥ {sys.float_info.min:.3g})")
    return value


def check_range(name: str, value: Any, lo: float = -math.inf, hi: float = math.inf,
                lo_open: bool = True, hi_open: bool = False) -> float:
    """Validate a finite real in the interval (lo, hi] (openness configurable)."""
    lb = "(" if lo_open else "["
    rb = ")" if hi_open or hi == math.inf else "]"
    allowed = f"a finite number in {lb}{lo:g}, {hi:g}{rb}"
    v = check_real(name, value, allowed)
    if (v <= lo if lo_open else v < lo) or (v >= hi if hi_open else v > hi):
        raise ParameterError(name, value, allowed)
    return v


def check_choice(name: str, value: Any, choices: tuple[str, ...]) -> str:
    if not isinstance(value, str) or value not in choices:
        raise ParameterError(name, value, "one of " + ", ".join(repr(c) for c in choices))
    return value


def positive(name: str, value: Any, hi: float = math.inf) -> float:
    return check_range(name, value, 0.0, hi)


def _set(obj, name, value):
    object.__setattr__(obj, name, value)


@dataclass(frozen=True)
class Filament:
    """Helical filament: discrete Kirchhoff rod of ``n_segments`` bonds of length h.

    Energy density (paper Eqs. (4)–(5))::

        f = A/2 Ω1² + A/2 (Ω2 − κ0)² + C/2 (Ω3 − τ0)² + K/2 (|∂s r| − 1)²

    ``tau0`` is the magnitude of the torsion; ``handedness`` gives its sign
    (right-handed: τ > 0).
    """

    kappa0: float = NORMAL_HELIX[0]  #: spontaneous curvature κ0 [1/µm] (the paper's normal helix)
    tau0: float = NORMAL_HELIX[1]  #: spontaneous torsion |τ0| [1/µm]
    handedness: str = "right"
    bend_rigidity: float = PAPER["bend_rigidity"].value  #: A [pN·µm²]
    twist_rigidity: float = PAPER["bend_rigidity"].value  #: C [pN·µm²] (the paper's C = A)
    stretch_modulus: float = 1.0e3  #: K [pN]; strain = tension/K
    length: float = 10.0  #: contour length L [µm]
    segment_length: float = 0.2  #: bond length h [µm]

    def __post_init__(self):
        for name in ("kappa0", "tau0"):
            v = check_range(name, getattr(self, name), 0.0, 1e3, lo_open=False)
            if 0 < v < 1e-6:
                raise ParameterError(name, v, "0 or a finite number in [1e-06, 1000]")
            _set(self, name, v)
        check_choice("handedness", self.handedness, ("right", "left"))
        _set(self, "bend_rigidity", positive("bend_rigidity", self.bend_rigidity, 1e6))
        _set(self, "twist_rigidity", positive("twist_rigidity", self.twist_rigidity, 1e6))
        _set(self, "stretch_modulus", positive("stretch_modulus", self.stretch_modulus, 1e9))
        _set(self, "length", positive("length", self.length, 1e4))
        h = positive("segment_length", self.segment_length, self.length / 3)
        n = self.length / h
        if not n <= MAX_SEGMENTS:
            raise ParameterError("segment_length", self.segment_length,
                                 f"at least length/{MAX_SEGMENTS} = {self.length / MAX_SEGMENTS:g} "
                                 f"(at most {MAX_SEGMENTS} segments)")
        if abs(n - round(n)) > 1e-6 * n or round(n) < 3:
            raise ParameterError("segment_length", self.segment_length,
                                 f"a divisor of length={self.length:g} giving at least 3 segments")
        _set(self, "segment_length", h)
        if self.kappa0 == 0 and self.tau0 == 0:
            pass  # straight rod is allowed
        if self.kappa0 * h > 1.0:
            raise ParameterError("segment_length", h,
                                 f"at most 1/kappa0 = {1 / self.kappa0:g} (bend angle per bond ≤ 1 rad)")

    @property
    def n_segments(self) -> int:
        """Number of bonds N = L/h (N+1 beads)."""
        return int(round(self.length / self.segment_length))

    @property
    def torsion(self) -> float:
        """Signed spontaneous torsion: +τ0 right-handed, −τ0 left-handed."""
        return self.tau0 if self.handedness == "right" else -self.tau0

    @property
    def chirality(self) -> int:
        return 1 if self.handedness == "right" else -1


@dataclass(frozen=True)
class Fluid:
    """Surrounding fluid and thermal bath."""

    viscosity: float = 1.0e-3  #: η [pN·s/µm²] (water)
    filament_radius: float = 0.01  #: r [µm]
    kT: float = 4.1e-3  #: thermal energy [pN·µm]; 0 switches noise off

    def __post_init__(self):
        _set(self, "viscosity", positive("viscosity", self.viscosity, 1e6))
        _set(self, "filament_radius", positive("filament_radius", self.filament_radius, 10.0))
        _set(self, "kT", check_range("kT", self.kT, 0.0, 10.0, lo_open=False))


@dataclass(frozen=True)
class Friction:
    """Local friction coefficients of resistive-force theory (paper Eqs. (6)–(7); Lighthill's
    values Eq. (33), App. A).

    ``model``:
      * ``"paper"`` — γ∥ = 1.6e-3, γ⊥ = 2.8e-3 pN·s/µm², γR = 1.26e-6 pN·s (default),
      * ``"lighthill"`` — Lighthill's formulas from η, r and the helix (App. A)::

            γ∥ = 2πη / ln(2q/r),   γ⊥ = 4πη / (ln(2q/r) + 1/2),   q = 0.09 Λ,
            Λ = 2πR / cos α,       γR = 4πη r²  (rotation of a cylinder about its axis)

      * ``"custom"`` — ``gamma_par``, ``gamma_perp``, ``gamma_rot`` as given.
    """

    model: str = "paper"
    gamma_par: float | None = None
    gamma_perp: float | None = None
    gamma_rot: float | None = None

    def __post_init__(self):
        check_choice("friction", self.model, ("paper", "lighthill", "custom"))
        for name in ("gamma_par", "gamma_perp", "gamma_rot"):
            v = getattr(self, name)
            if v is not None:
                lo, hi = FRICTION_RANGE[name]
                _set(self, name, check_range(name, v, lo, hi, lo_open=False))
            elif self.model == "custom":
                raise ParameterError(name, v, "given (a number > 0) when friction = 'custom'")

    def resolve(self, filament: Filament, fluid: Fluid) -> tuple[float, float, float]:
        """The (γ∥, γ⊥, γR) in use."""
        if self.model == "paper":
            base = PAPER_FRICTION
        elif self.model == "lighthill":
            base = lighthill_friction(filament, fluid)
        else:
            base = (self.gamma_par, self.gamma_perp, self.gamma_rot)
        given = (self.gamma_par, self.gamma_perp, self.gamma_rot)
        out = tuple(float(g if g is not None else b) for g, b in zip(given, base))
        for (name, (lo, hi)), g in zip(FRICTION_RANGE.items(), out):
            if not lo <= g <= hi:
                raise ParameterError(name, g, f"in [{lo:g}, {hi:g}] (friction = '{self.model}': "
                                     "viscosity and filament radius set it)")
        return out


def lighthill_friction(filament: Filament, fluid: Fluid) -> tuple[float, float, float]:
    """Lighthill's local friction coefficients (paper App. A) for the filament's helix."""
    k2 = filament.kappa0**2 + filament.tau0**2
    if filament.kappa0 == 0:
        raise ParameterError("kappa0", 0.0, "> 0 for Lighthill friction (needs a helix)")
    radius = filament.kappa0 / k2
    cos_alpha = filament.kappa0 / math.sqrt(k2)
    q = 0.09 * 2 * math.pi * radius / cos_alpha
    log = math.log(2 * q / fluid.filament_radius)
    if log <= 0:
        raise ParameterError("filament_radius", fluid.filament_radius,
                             f"smaller than 2q = {2 * q:g} µm for Lighthill friction")
    eta = fluid.viscosity
    return (2 * math.pi * eta / log, 4 * math.pi * eta / (log + 0.5),
            4 * math.pi * eta * fluid.filament_radius**2)


@dataclass(frozen=True)
class EndLoad:
    """A load on the free end (the last bead), along the motor axis.

    ``force`` [pN]: a constant force pulling the free end along −e_z, i.e. away from the
    motor, so that it extends the filament (F > 0 stretches; F < 0 pushes the end towards
    the motor). ``trap_stiffness`` k [pN/µm]: an axial trap (it acts on the z coordinate
    only, as a force clamp) whose centre starts at the free end of the initial filament and
    moves along −e_z at ``pull_rate`` v [µm/s]; its force k (z_c(t) − z_N) adds to ``force``.
    """

    force: float = 0.0
    pull_rate: float = 0.0
    trap_stiffness: float = 0.0

    def __post_init__(self):
        _set(self, "force", check_range("end_force", self.force, -1e4, 1e4))
        _set(self, "trap_stiffness", check_range("trap_stiffness", self.trap_stiffness, 0.0, 1e5,
                                                 lo_open=False))
        _set(self, "pull_rate", check_range("pull_rate", self.pull_rate, -1e4, 1e4))
        if self.pull_rate != 0.0 and self.trap_stiffness == 0.0:
            raise ParameterError("pull_rate", self.pull_rate, "0 unless trap_stiffness > 0 "
                                 "(the rate moves the trap's centre)")

    @property
    def active(self) -> bool:
        return self.force != 0.0 or self.trap_stiffness != 0.0


#: Polymorphic forms of the flagellar filament: name → (pitch [µm], helix diameter [µm],
#: handedness relative to the normal form: +1 the same, −1 the opposite). The E. coli forms
#: of a tumble as N. C. Darnton, L. Turner, S. Rojevsky & H. C. Berg, J. Bacteriol. 189, 1756
#: (2007), introduction, describe them: normal "a left-handed helix with a pitch of 2.3 µm
#: and a diameter of 0.4 µm", semicoiled "a right-handed helix with half the normal pitch but
#: normal amplitude", curly 1 "a right-handed helix with half the normal pitch and half the
#: normal amplitude" (amplitude: the helix radius). The normal form of a :class:`Polymorphism`
#: is the filament's own helix (κ0, τ0; the paper's: pitch 2.16 µm, diameter 0.43 µm), so
#: that a one-form filament is the paper's.
POLYMORPHIC_FORMS = {
    "normal": (2.3, 0.4, 1),
    "semicoiled": (1.15, 0.4, -1),
    "curly1": (1.15, 0.2, -1),
    # the form before normal in Calladine's sequence (Calladine, J. Mol. Biol. 118, 457
    # (1978)), left-handed like it, of nearly zero pitch: a placeholder of that description,
    # not numbers read from an article (docs/polymorphism.md)
    "coiled": (0.3, 0.9, 1),
}


def helix_strains(pitch: float, diameter: float) -> tuple[float, float]:
    """(κ, |τ|) [1/µm] of the helix of ``pitch`` and ``diameter``: with R = D/2, b = P/2π,
    κ = R/(R² + b²), τ = b/(R² + b²)."""
    r, b = diameter / 2, pitch / (2 * math.pi)
    return r / (r * r + b * b), b / (r * r + b * b)


@dataclass(frozen=True)
class Polymorphism:
    """A multistable filament (:mod:`flagellum.rod.polymorph`): each joint carries an order
    parameter φ whose integer values 0, 1, … are the ``forms`` in order (a form's intrinsic
    curvature and torsion at φ = its index, linear in between).

    Landscape (energy per length [pN]) between neighbouring forms m, m+1, x = φ − m:
    v = ε_m + k q(x; a_m), q = x⁴/4 − (1 + a) x³/3 + a x²/2 with k = 64·``barrier`` and
    a_m = 1/2 + 6 (ε_{m+1} − ε_m)/k, so that v(m) = ε_m, both forms are minima (v' = 0) and,
    for equal ε, the barrier between them is ``barrier`` high; ``barrier`` is one number for
    every pair, or one per neighbouring pair (len(forms) − 1 numbers, k_m = 64·barrier_m). ``energies`` ε [pN] (default 0
    for every form). Domain walls cost D/2 (∂φ/∂s)² per length, D = ``wall_stiffness``
    [pN·µm²]; ``friction`` ζ [pN·s] sets the overdamped dynamics ζ ∂φ/∂t = −δE/δφ (+ noise of
    a thermal run). ``initial``: the starting form of every joint (default: the first
    form), or ``"form:count,…"`` along the filament from the motor (counts summing to the
    segment count).
    """

    forms: tuple = ("normal", "semicoiled", "curly1")
    energies: tuple | None = None
    #: fitted to the threshold torque of normal → semicoiled, −1.1 pN·µm (Hotani, J. Mol.
    #: Biol. 156, 791 (1982)), with ``wall_stiffness`` (docs/polymorphism.md)
    barrier: float = 0.25
    wall_stiffness: float = 0.5
    friction: float = 0.1
    initial: str | None = None

    def __post_init__(self):
        forms = tuple(self.forms) if not isinstance(self.forms, str) else tuple(
            f.strip() for f in self.forms.split(","))
        if not forms or any(f not in POLYMORPHIC_FORMS for f in forms) or len(set(forms)) != len(forms):
            raise ParameterError("polymorphic", ",".join(map(str, forms)), "distinct forms among "
                                 + ", ".join(POLYMORPHIC_FORMS))
        _set(self, "forms", forms)
        if isinstance(self.barrier, (tuple, list)):
            if len(self.barrier) != max(len(forms) - 1, 1):
                raise ParameterError("polymorph_barrier", ",".join(map(str, self.barrier)),
                                     f"one number, or {max(len(forms) - 1, 1)} (one per "
                                     "neighbouring pair of forms)")
            _set(self, "barrier", tuple(positive("polymorph_barrier", b, 1e4) for b in self.barrier))
        else:
            _set(self, "barrier", positive("polymorph_barrier", self.barrier, 1e4))
        _set(self, "wall_stiffness", positive("polymorph_wall_stiffness", self.wall_stiffness, 1e6))
        _set(self, "friction", positive("polymorph_friction", self.friction, 1e6))
        if self.energies is None:
            _set(self, "energies", (0.0,) * len(forms))
        e = tuple(check_real("polymorph_energies", v) for v in self.energies)
        if len(e) != len(forms):
            raise ParameterError("polymorph_energies", ",".join(map(str, e)),
                                 f"{len(forms)} numbers (one per form)")
        kk = self.pair_stiffness()
        if any(abs(b - a) >= k / 12 for a, b, k in zip(e, e[1:], kk)):
            raise ParameterError("polymorph_energies", ",".join(map(str, e)), "neighbouring "
                                 f"differences below 16/3 × barrier = {min(kk) / 12:g} pN "
                                 "(both forms minima)")
        _set(self, "energies", e)
        if self.initial is None:
            _set(self, "initial", forms[0])
        if not isinstance(self.initial, str):
            raise ParameterError("polymorph_initial", self.initial, "a form or 'form:count,…'")

    def pair_barriers(self) -> tuple:
        """The barrier [pN] of each neighbouring pair of forms (at least one entry)."""
        b = self.barrier
        return tuple(b) if isinstance(b, tuple) else (b,) * max(len(self.forms) - 1, 1)

    def pair_stiffness(self) -> tuple:
        """The well stiffness k_m = 64·barrier_m [pN] of each neighbouring pair."""
        return tuple(64.0 * b for b in self.pair_barriers())

    def initial_states(self, n: int) -> "list[int]":
        """The starting form index of each of the n joints."""
        items = [p.strip() for p in self.initial.split(",")]
        allowed = "a form of --polymorphic or 'form:count,…' with counts summing to the segments"
        out: list[int] = []
        for item in items:
            name, _, count = item.partition(":")
            if name not in self.forms:
                raise ParameterError("polymorph_initial", self.initial, allowed)
            try:
                c = int(count) if count else (n if len(items) == 1 else -1)
            except ValueError:
                c = -1
            if c < 0:
                raise ParameterError("polymorph_initial", self.initial, allowed)
            out += [self.forms.index(name)] * c
        if len(out) != n:
            raise ParameterError("polymorph_initial", self.initial, allowed + f" ({n})")
        return out

    def strains(self, filament: "Filament") -> tuple[tuple, tuple]:
        """(κ, signed τ) [1/µm] of each form for ``filament``: the normal form is the
        filament's helix, the others from :data:`POLYMORPHIC_FORMS` with their handedness
        relative to it."""
        kap, tau = [], []
        for f in self.forms:
            if f == "normal":
                k, t = filament.kappa0, filament.torsion
            else:
                pitch, diameter, hand = POLYMORPHIC_FORMS[f]
                k, t = helix_strains(pitch, diameter)
                t *= hand * filament.chirality
            kap.append(k)
            tau.append(t)
        return tuple(kap), tuple(tau)


_SECTIONS = {"filament": Filament, "fluid": Fluid, "friction": Friction}


@dataclass(frozen=True)
class Params:
    """All physical parameters of a filament in a fluid."""

    filament: Filament = field(default_factory=Filament)
    fluid: Fluid = field(default_factory=Fluid)
    friction: Friction = field(default_factory=Friction)

    @property
    def gammas(self) -> tuple[float, float, float]:
        """(γ∥, γ⊥, γR) in use."""
        return self.friction.resolve(self.filament, self.fluid)

    def to_dict(self) -> dict:
        d = asdict(self)
        d["friction"] = {k: v for k, v in d["friction"].items() if v is not None}
        return d

    @classmethod
    def from_dict(cls, data: dict) -> "Params":
        """Build from nested ``{"filament": {...}, "fluid": {...}, "friction": {...}}``."""
        if not isinstance(data, dict):
            raise ParameterError("config", type(data).__name__, "a table of sections")
        unknown = set(data) - set(_SECTIONS)
        if unknown:
            raise ParameterError("config section", sorted(unknown)[0],
                                 "one of " + ", ".join(_SECTIONS))
        parts = {}
        for sec, klass in _SECTIONS.items():
            values = data.get(sec, {})
            if not isinstance(values, dict):
                raise ParameterError(sec, values, "a table")
            values = dict(values)
            if sec == "friction" and "friction" in values:
                values["model"] = values.pop("friction")
            names = {f.name for f in fields(klass)}
            bad = set(values) - names
            if bad:
                raise ParameterError(f"{sec}.{sorted(bad)[0]}", values[sorted(bad)[0]],
                                     "a known key: " + ", ".join(sorted(names)))
            parts[sec] = klass(**values)
        return cls(**parts)

    @classmethod
    def from_flat(cls, values: dict, base: "Params | None" = None) -> "Params":
        """Override ``base`` with flat names as used by the CLI (``None`` values ignored)."""
        base = base or cls()
        nested = base.to_dict()
        for key, v in values.items():
            if v is None:
                continue
            for sec, klass in _SECTIONS.items():
                names = {f.name for f in fields(klass)}
                if key in names:
                    nested[sec][key] = v
                    break
                if sec == "friction" and key == "friction":
                    nested[sec]["model"] = v
                    break
            else:
                raise ParameterError("parameter", key, "a known parameter name")
        return cls.from_dict(nested)

    def replace(self, **flat) -> "Params":
        """Copy with flat-named parameters replaced, e.g. ``p.replace(length=5.0)``."""
        return Params.from_flat(flat, base=self)

    def to_toml(self) -> str:
        lines = []
        for sec, values in self.to_dict().items():
            lines.append(f"[{sec}]")
            for k, v in values.items():
                lines.append(f"{k} = {v!r}" if not isinstance(v, str) else f'{k} = "{v}"')
            lines.append("")
        return "\n".join(lines)

    def save_toml(self, path: str | Path) -> None:
        from .io import atomic_write_text

        atomic_write_text(path, self.to_toml())

    @classmethod
    def load_toml(cls, path: str | Path) -> "Params":
        return cls.from_dict(read_toml(path))


def read_toml(path: str | Path) -> dict:
    """Read a TOML file, turning every failure into a one-line :class:`ParameterError`."""
    from .io import read_text

    text = read_text(path, "config")
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ParameterError("config", str(path), f"valid TOML ({exc})")


__all__ = ["EndLoad", "POLYMORPHIC_FORMS", "Polymorphism", "helix_strains", "FRICTION_RANGE", "MAX_SEGMENTS", "Filament", "Fluid", "Friction", "Params", "PAPER_FRICTION", "lighthill_friction",
           "check_real", "check_range", "check_choice", "positive", "read_toml"]
