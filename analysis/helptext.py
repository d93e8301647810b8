"""The help texts of ./afm's commands: docs/help/COMMAND.txt, one file per
command, which ./afm prints for COMMAND --help (before anything is set up)
and each command's program prints at the head of its own --help, so the two
cannot drift."""
import os

from analysis import paths


def text(command):
    """docs/help/COMMAND.txt as it stands (a short note if it is missing)."""
    path = os.path.join(paths.ROOT, "docs", "help", f"{command}.txt")
    try:
        with open(path) as f:
            return f.read().rstrip("\n")
    except OSError:
        return f"(no help text: {path} is missing)"
