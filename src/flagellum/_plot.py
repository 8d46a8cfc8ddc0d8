"""Matplotlib for the figures the package writes (theory, viz, reproduce)."""

from __future__ import annotations


def pyplot():
    """``matplotlib.pyplot`` on the Agg backend.

    Every figure of the package is written to a file, so the non-interactive Agg backend is
    selected even where a display exists: the files then do not depend on the GUI toolkit
    installed, and no window opens.
    """
    import matplotlib

    matplotlib.use("Agg", force=True)
    import matplotlib.pyplot as plt

    return plt


__all__ = ["pyplot"]
