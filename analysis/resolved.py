"""A scene as the launcher resolves it: `afm_launch --scene FILE --resolved`
(the C++ reader: the scene checked, its includes merged in, its file names
made absolute). The one way Python reads a scene's merged content; nothing
here restates the include rule."""
import subprocess

import yaml

from analysis import paths

TIMEOUT_S = 60


class SceneRefused(Exception):
    """The launcher could not read the scene, or refused it (its own words)."""


def resolved_scene(scene_path):
    """The resolved scene, a mapping; SceneRefused with the launcher's line."""
    try:
        p = subprocess.run([paths.LAUNCH, "--scene", scene_path, "--resolved", "--quiet"], capture_output=True,
                           text=True, timeout=TIMEOUT_S)
    except (OSError, subprocess.TimeoutExpired) as e:
        raise SceneRefused(f"{scene_path}: the launcher could not read the scene: {e}") from None
    if p.returncode != 0:
        raise SceneRefused((p.stderr.strip().splitlines() or [f"{paths.LAUNCH} --resolved: exit {p.returncode}"])[-1])
    try:
        scene = yaml.safe_load(p.stdout)
    except yaml.YAMLError as e:
        raise SceneRefused(f"{scene_path}: the launcher's resolved scene is not YAML ({str(e).splitlines()[0]})") from None
    if not isinstance(scene, dict):
        raise SceneRefused(f"{scene_path}: the launcher's resolved scene is not a mapping")
    return scene
