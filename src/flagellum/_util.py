"""Small helpers shared by several layers: JSON-ready values."""

from __future__ import annotations

import math

import numpy as np


def jsonable(obj):
    """``obj`` with numpy scalars and arrays turned into Python numbers and lists, tuples into
    lists, dict keys into strings, and non-finite floats into ``None`` (JSON has no NaN)."""
    if isinstance(obj, dict):
        return {str(k): jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple, np.ndarray)):
        return [jsonable(v) for v in obj]
    if isinstance(obj, (np.floating, float)):
        return float(obj) if math.isfinite(obj) else None
    if isinstance(obj, np.integer):
        return int(obj)
    if isinstance(obj, np.bool_):
        return bool(obj)
    return obj
