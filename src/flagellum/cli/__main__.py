"""``python -m flagellum.cli``: the command-line interface."""

from . import entry

if __name__ == "__main__":
    entry()
