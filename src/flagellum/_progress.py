"""Progress bars (``tqdm.auto``: a widget in Jupyter, text on a terminal) and when to show them."""

from __future__ import annotations

import sys


def interactive() -> bool:
    """Whether someone watches: stderr is a terminal, or the code runs in a Jupyter kernel
    (whose stderr is no terminal but shows the bar as a widget)."""
    try:
        if sys.stderr is not None and sys.stderr.isatty():
            return True
    except (AttributeError, ValueError):  # replaced or closed stderr
        pass
    ipython = sys.modules.get("IPython")
    shell = getattr(ipython, "get_ipython", lambda: None)() if ipython is not None else None
    return type(shell).__name__ == "ZMQInteractiveShell"


def show_progress(progress: bool | None) -> bool:
    """``progress`` as given, or :func:`interactive` for None."""
    return interactive() if progress is None else bool(progress)


def progress_bar(**kwargs):
    """A ``tqdm.auto`` bar with ``kwargs`` (``total``, ``unit``, ``desc``, ``disable``, …),
    adapting to the terminal width."""
    import warnings

    with warnings.catch_warnings():  # tqdm.auto falls back to text without ipywidgets
        warnings.simplefilter("ignore")
        from tqdm.auto import tqdm
    return tqdm(dynamic_ncols=True, **kwargs)


__all__ = ["interactive", "progress_bar", "show_progress"]
