"""The arguments every benchmark shares, checked in one place: --repeat
(1 or more) and --scene (a file that is there). Refused with argparse's
usage line, naming the option and the value."""
import os


def checked_scene(ap, a):
    """Refuses a --repeat below 1 or a --scene that is not there; the scene's absolute path."""
    if a.repeat < 1:
        ap.error(f"--repeat: {a.repeat}: give 1 or more")
    if not os.path.isfile(a.scene):
        ap.error(f"--scene: {a.scene}: no such file")
    return os.path.abspath(a.scene)
