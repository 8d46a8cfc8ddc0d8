"""Deterministic stiff integration: SUNDIALS CVODE (variable-order BDF, error control).

CVODE (through scikit-sundae) takes the right-hand side from the Numba kernel and the
banded Jacobian from :func:`flagellum.rod.kernels.colored_jacobian` in a single call, so that
a Jacobian costs one kernel evaluation per colour (23 for the rod; kl + ku + 1 = 28 for a full
band) and no Python round trips per column.
See ``docs/numerics.md`` for the comparison with scipy's BDF/Radau/LSODA that chose it.

With a nonlocal mobility the Jacobian is dense; the Newton systems are then solved by GMRES
(matrix-free products from the right-hand side) preconditioned by the factorized banded
iteration matrix I − γJ of the local operator plus the near field of ΔM, the splitting of
Tornberg & Shelley (2004) (docs/hydrodynamics.md).
"""

from __future__ import annotations

import contextlib
import functools
import io
import os
import re
import sys
import tempfile
import warnings

import numpy as np
from numba import njit

from ..errors import SimulationError
from . import MAX_STEPS_PER_ADVANCE
from .banded import band_factor, band_solve
from .frozen import FrozenMobility
from ..rod import kernels as K
from ..rod.model import JACOBIAN_BAND

KL, KU = JACOBIAN_BAND


@njit(cache=True)
def _band_to_dense(ab, kl, ku, out):
    """Copy the band of ``ab`` into the (n, n) array that scikit-sundae hands to the Jacobian
    callback; it reads back only the band, so the rest is not touched (zeroing all n² entries
    made the Jacobian cost quadratic in N)."""
    n = ab.shape[0]
    kv = kl + ku
    for j in range(n):
        for i in range(max(0, j - ku), min(n, j + kl + 1)):
            out[i, j] = ab[j, kv + i - j]


@functools.cache
def _c_fflush():
    """C's ``fflush`` (looked up once: a lookup costs 60 µs, a call 0.2 µs), or None."""
    import ctypes

    try:
        return ctypes.CDLL(None).fflush
    except (OSError, AttributeError):  # pragma: no cover - no C library to ask
        return None


def _flush_c_streams() -> None:
    """Flush C's stdio buffers (SUNDIALS' logger writes through them)."""
    fflush = _c_fflush()
    if fflush is not None:
        fflush(None)


class SundialsOutput:
    """What SUNDIALS prints while CVODE steps, caught instead of reaching the terminal:
    its warnings ("t + h = t on the next step"), which its logger writes to C's stdout
    (file descriptor 1), and its errors, which scikit-sundae's error handler prints to
    Python's stdout. Inside :meth:`catch` both file descriptors 1 and 2 and ``sys.stdout``
    go to a private file; :attr:`warnings` and :attr:`errors` then hold the messages of that
    call, without SUNDIALS' ``[WARNING][rank 0][file:line][CVode]`` prefixes."""

    _PREFIX = re.compile(r"^(?:\[[^\]]*\])+\s*")

    def __init__(self):
        self._file = None
        self.warnings: list[str] = []
        self.errors: list[str] = []

    @contextlib.contextmanager
    def catch(self):
        if self._file is None:
            self._file = tempfile.TemporaryFile()
        text = io.StringIO()
        for stream in (sys.stdout, sys.stderr):
            with contextlib.suppress(Exception):
                stream.flush()
        _flush_c_streams()
        if os.fstat(self._file.fileno()).st_size:
            self._file.seek(0)
            self._file.truncate()
        saved = []
        try:
            for fd in (1, 2):
                saved.append((fd, os.dup(fd)))
                os.dup2(self._file.fileno(), fd)
        except OSError:  # a closed descriptor: nothing of C's to catch there
            pass
        try:
            with contextlib.redirect_stdout(text):
                yield self
        finally:
            _flush_c_streams()
            for fd, copy in saved:
                os.dup2(copy, fd)
                os.close(copy)
            raw = text.getvalue()
            if os.fstat(self._file.fileno()).st_size:
                self._file.seek(0)
                raw = self._file.read().decode(errors="replace") + "\n" + raw
            self.warnings, self.errors = [], []
            for line in raw.splitlines():
                if line.strip():
                    (self.warnings if line.startswith("[WARNING]") else self.errors).append(
                        self._PREFIX.sub("", line.strip()))

    def summary(self) -> str:
        """The messages of the last call in one line ('' if there were none)."""
        parts = []
        if self.errors:
            parts.append(self.errors[-1])
        if self.warnings:
            n = len(self.warnings)
            parts.append(f"{n} warning{'s' if n > 1 else ''}, the first: {self.warnings[0]}")
        return "; ".join(" ".join(p.split()) for p in parts)


class CvodeStepper:
    """Advance a :class:`~flagellum.rod.model.RodModel` state with CVODE BDF.

    ``advance(t)`` integrates to time t and returns the state; the stepper keeps CVODE's
    history between calls, and restarts it (cheaply) when :meth:`reset` is called after a
    change of the right-hand side (new chart, new frame rate). Satisfies
    :class:`flagellum.integrate.base.Stepper` (adaptive: ``fixed_step`` is None;
    deterministic: ``rng_state`` is None). ``max_num_steps``: CVODE's limit of internal
    steps per :meth:`advance` (per CVODE call with a frozen nonlocal mobility).
    """

    fixed_step = None
    rng_state = None

    def __init__(self, model, t0: float, y0: np.ndarray, rtol: float = 1e-6,
                 atol: float = 1e-8, max_step: float = 0.0,
                 max_num_steps: int = MAX_STEPS_PER_ADVANCE):
        try:
            from sksundae.cvode import CVODE
        except ImportError as exc:  # pragma: no cover - dependency declared
            raise SimulationError("method 'cvode' needs scikit-sundae (pip install scikit-sundae)") from exc
        self._CVODE = CVODE
        self.model = model
        self.rtol, self.atol, self.max_step = rtol, atol, max_step
        self.max_num_steps = int(max_num_steps)
        n = len(y0)
        self._kl, self._ku = model.jacobian_band  # JACOBIAN_BAND, wider with a nonlocal mobility
        self._ab = np.zeros((n, 2 * self._kl + self._ku + 1))
        self._yw = np.zeros(n)
        self._fw = np.zeros(n)
        self._f0 = np.zeros(n)
        # CVODE hands read-only views of its vectors to the callbacks; the kernels get them
        # copied into writable arrays, so that they are compiled for one array type only
        # (a read-only argument is another Numba signature: a second compile of the rod
        # kernels, ≈ 10 s on the first run after installing)
        self._y = np.zeros(n)
        self._pab = np.zeros_like(self._ab)  # factorized I − γJ (nonlocal: the preconditioner)
        self._ipiv = np.zeros(n, np.int64)
        self._backup = np.zeros((n, self._kl + self._ku + 1))
        self._pivoted = True
        self.n_jac = 0
        self.n_steps = 0
        self._t_max = -np.inf
        self._output = SundialsOutput()
        self._warned: set[str] = set()
        self._frozen = FrozenMobility(model)
        self.reset(t0, y0)

    @property
    def tracks_mobility(self) -> bool:
        """Whether :meth:`advance` renews a frozen nonlocal ΔM itself (and applies its secant model)."""
        return self._frozen.active

    @classmethod
    def from_options(cls, model, t: float, y: np.ndarray, options, *, kT: float = 0.0,
                     seed: int = 0, rng_state=None) -> "CvodeStepper":
        """The stepper of ``options`` (``rtol``, ``atol``, ``max_steps``); deterministic, so
        ``kT``, ``seed`` and ``rng_state`` are not used."""
        return cls(model, t, y, options.rtol, options.atol, max_num_steps=options.max_steps)

    def _rhs(self, t, y, yp):
        if t > self._t_max:  # a new step attempt (CVODE does not expose its counters here)
            self._t_max = t
            self.n_steps += 1
        self._y[:] = y
        self._frozen.apply(self._y)  # the secant model of ΔM at y
        self.model.rhs(t, self._y, out=yp)

    def _writable(self, y, yp):
        self._y[:] = y
        self._f0[:] = yp
        return self._y, self._f0

    def _jac(self, t, y, yp, jj):
        m = self.model
        m.prm[K.P_TORQUE] = m.motor(t)
        y, yp = self._writable(y, yp)
        m.jacobian_kernel(y, yp, *m.kernel_arrays, self._kl, self._ku, self._ab, 1.0, self._yw,
                          self._fw, *m.jacobian_colors(self._kl, self._ku))
        _band_to_dense(self._ab, self._kl, self._ku, jj)
        self.n_jac += 1

    def _band_jacobian(self, t, y, yp):
        m = self.model
        m.prm[K.P_TORQUE] = m.motor(t)
        y, yp = self._writable(y, yp)
        m.jacobian_kernel(y, yp, *m.kernel_arrays, self._kl, self._ku, self._ab, 1.0, self._yw,
                          self._fw, *m.jacobian_colors(self._kl, self._ku))
        self.n_jac += 1

    def _psetup(self, t, y, yp, jok, jnew, gamma):
        if not jok:
            self._band_jacobian(t, y, yp)
        jnew[0] = 0 if jok else 1
        kv = self._kl + self._ku
        self._pab[:] = -gamma * self._ab
        self._pab[:, kv] += 1.0
        info, self._pivoted = band_factor(self._pab, self._kl, self._ku, self._ipiv, self._backup)
        if info != 0:
            raise SimulationError(f"singular preconditioner at t = {t:.6g} s")

    def _psolve(self, t, y, yp, rvec, zvec, gamma, delta, lr):
        zvec[:] = rvec
        band_solve(self._pab, self._kl, self._ku, self._ipiv, zvec, self._pivoted)

    def reset(self, t0: float, y0: np.ndarray) -> None:
        self.t = float(t0)
        self.y = np.array(y0, float)
        self._frozen.reset(t0)  # (a resumed run starts here too: nothing carried over)
        if self.model.jacobian_band == (KL, KU):
            linear = dict(jacfn=self._jac, linsolver="band", lband=self._kl, uband=self._ku)
        else:
            from sksundae.cvode import CVODEPrecond

            linear = dict(linsolver="gmres", krylov_dim=10,
                          precond=CVODEPrecond(self._psetup, self._psolve, side="left"))
        self._solver = self._CVODE(self._rhs, **linear, rtol=self.rtol, atol=self.atol,
                                   max_step=self.max_step, max_num_steps=self.max_num_steps)
        self._solver.init_step(self.t, self.y)

    def _step_to(self, t: float):
        res = self._solver.step(t)
        return res.success and bool(np.all(np.isfinite(res.y))), res.y, res

    def advance(self, t: float) -> np.ndarray:
        with self._output.catch() as said:  # SUNDIALS' own lines: folded into ours
            if not self._frozen.active:
                res = self._solver.step(t)
            else:  # CVODE's steps are not stopped at the sub-targets: it interpolates
                res = self._frozen.advance(self.t, self.y, t, self._step_to)
        if not res.success or not np.all(np.isfinite(res.y)):
            detail = said.summary()
            raise SimulationError(f"CVODE failed at t = {res.t:.6g} s: {res.message}"
                                  + (f" (SUNDIALS: {detail})" if detail else ""))
        for msg in said.warnings + said.errors:  # a step that went on: a Python warning, once per kind
            kind = re.sub(r"[-+.\deE]+", "#", msg)
            if kind not in self._warned:
                self._warned.add(kind)
                warnings.warn(f"CVODE: {msg}", RuntimeWarning, stacklevel=2)
        self.t, self.y = float(res.t), np.array(res.y, float)
        return self.y
