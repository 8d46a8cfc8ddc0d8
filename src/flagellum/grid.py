"""Sweepable parameters and their values: names, types, and the range syntax of sweeps.

Shared by the sweep engine (:mod:`flagellum.sweep`), the bifurcation search
(:mod:`flagellum.analysis.bifurcations`) and their command lines: a value is given as
``start:stop[:step]`` (``stop`` included when it lies on the grid; decimal arithmetic, so
``0:0.3:0.1`` gives 0.3, not 0.30000000000000004), ``a,b,c``, one value or a list.
"""

from __future__ import annotations

import math
from dataclasses import fields
from decimal import Decimal, InvalidOperation
from typing import Any

import numpy as np

from .errors import ParameterError
from .params import Filament, Fluid

#: Sweepable parameters and their types: the model parameters (as in ``Params.from_flat``),
#: motor, boundary, hydrodynamics, run length and solver settings.
MODEL_PARAMETERS: dict[str, type] = {
    **{f.name: (str if f.name == "handedness" else float) for k in (Filament, Fluid) for f in fields(k)},
    "friction": str, "gamma_par": float, "gamma_perp": float, "gamma_rot": float,
}
PARAMETERS: dict[str, type] = {
    **MODEL_PARAMETERS, "torque": float, "motor_speed": float, "motor_law": str, "ramp_time": float,
    "reversal_times": tuple, "reversal_rates": tuple, "reversal_seed": int,
    "anchor": str, "sphere_radius": float, "hook": str, "hook_stiffness": float,
    "body_radius": float, "body_aspect": float, "motor_offset": float,
    "hydrodynamics": str, "hydro_refresh": float,
    "time": float, "save_every": float, "average_from": float,
    "thermal": bool, "seed": int, "method": str, "rtol": float, "dt": float,
}
ALIASES = {"t_end": "time"}
MAX_POINTS = 1_000_000  #: largest number of values of a range (and of grid points of a sweep)


def canonical_name(name: str) -> str:
    """The parameter name as stored (``--sphere-radius`` → ``sphere_radius``, ``t_end`` → ``time``)."""
    key = str(name).lstrip("-").replace("-", "_")
    key = ALIASES.get(key, key)
    if key not in PARAMETERS:
        raise ParameterError("parameter", name, "a sweepable parameter (" + ", ".join(PARAMETERS) + ")")
    return key


def convert(name: str, value: Any):
    """One value of parameter ``name`` as its type (float, int, str, bool)."""
    typ = PARAMETERS[name]
    text = value.strip() if isinstance(value, str) else value
    try:
        if typ is tuple:  # a list of numbers is one value (e.g. the reversal times of a run)
            items = text.split(",") if isinstance(text, str) else text
            if isinstance(items, (str, bool)) or not isinstance(items, (list, tuple, np.ndarray)):
                raise ValueError
            return tuple(convert_number(name, x) for x in items)
        if typ is str:
            if not isinstance(text, str) or not text:
                raise ValueError
            return text
        if typ is bool:
            if isinstance(text, str) and text.lower() in ("true", "false"):
                return text.lower() == "true"
            if not isinstance(text, bool):
                raise ValueError
            return text
        if isinstance(text, bool):
            raise ValueError
        if typ is int:
            d = Decimal(text)
            if not d.is_finite() or d != d.to_integral_value():
                raise ValueError
            return int(d)
        v = float(text)
        if not math.isfinite(v):
            raise ValueError
        return v
    except (ValueError, TypeError, OverflowError, InvalidOperation, ParameterError):
        kind = {float: "a finite number", int: "an integer", str: "a non-empty string",
                bool: "true or false", tuple: "comma-separated finite numbers"}[typ]
        raise ParameterError(name, value, kind) from None


def convert_number(name: str, value: Any) -> float:
    """One finite number of a list-valued parameter ``name``."""
    if isinstance(value, bool):
        raise ParameterError(name, value, "a finite number")
    try:
        v = float(value.strip() if isinstance(value, str) else value)
    except (ValueError, TypeError, OverflowError):
        raise ParameterError(name, value, "a finite number") from None
    if not math.isfinite(v):
        raise ParameterError(name, value, "a finite number")
    return v


def _range(name: str, text: str) -> list:
    """Values of ``start:stop[:step]``; ``stop`` is included when it lies on the grid."""
    parts = text.split(":")
    try:
        if len(parts) not in (2, 3) or PARAMETERS[name] not in (float, int):
            raise InvalidOperation
        start, stop, step = (Decimal(p.strip()) for p in parts + ["1"] * (3 - len(parts)))
        if not all(x.is_finite() for x in (start, stop, step)) or step == 0 or (stop - start) * step < 0:
            raise InvalidOperation
        n = int((stop - start) / step) + 1
    except (InvalidOperation, ArithmeticError):
        raise ParameterError(name, text, "start:stop or start:stop:step of numbers, the step "
                                         "nonzero and pointing from start to stop") from None
    if n > MAX_POINTS:
        raise ParameterError(name, text, f"a range of at most {MAX_POINTS} values")
    return [convert(name, start + i * step) for i in range(n)]


def parse_values(name: str, spec: Any) -> tuple:
    """Values of a parameter from ``"start:stop[:step]"``, ``"a,b,c"``, one value, or a list.

    >>> len(parse_values("torque", "-2:6:0.25")), parse_values("seed", "1:3")
    (33, (1, 2, 3))
    """
    name = canonical_name(name)
    if PARAMETERS[name] is tuple:  # "a,b" or [a, b]: one list; [[a, b], [c]]: several
        many = isinstance(spec, (list, tuple)) and any(isinstance(s, (list, tuple)) for s in spec)
        values = [convert(name, s) for s in spec] if many else [convert(name, spec)]
    elif isinstance(spec, str) and ":" in spec:
        values = _range(name, spec)
    elif isinstance(spec, str):
        values = [convert(name, s) for s in spec.split(",")]
    elif isinstance(spec, (list, tuple, np.ndarray)):
        values = [convert(name, s.item() if isinstance(s, np.generic) else s) for s in spec]
    else:
        values = [convert(name, spec)]
    if not values or len(set(values)) != len(values):
        raise ParameterError(name, spec, "a non-empty list of distinct values")
    return tuple(values)


__all__ = ["ALIASES", "MAX_POINTS", "MODEL_PARAMETERS", "PARAMETERS", "canonical_name", "convert",
           "convert_number", "parse_values"]
