"""The sweep's knobs: scene keys varied over lists of values.

A knob is a dotted path into the scene (firmware.adc_bits, sample_rate_hz,
sample.wire.segments, outputs.update_mode, ...), or effects.NAME with the
values on and off (the effect listed or not). Values are YAML scalars
(10, 1.5, true, local). Nothing is checked here beyond the knob's syntax:
the scene's validator and the firmware's card own every rule, and the sweep
asks them (afm_launch --check) for every point before anything starts.
"""
import copy
import itertools
import os

import yaml


class KnobError(ValueError):
    """A knob the sweep cannot use; its message names where it came from."""


def parse_value(text, where):
    text = text.strip()
    if text == "":
        raise KnobError(f"{where}: an empty value in the list")
    try:
        v = yaml.safe_load(text)
    except yaml.YAMLError:
        raise KnobError(f"{where}: value {text!r} is not a YAML scalar") from None
    if isinstance(v, (list, dict)) or v is None:
        raise KnobError(f"{where}: value {text!r} must be one number, word or true/false")
    return v


def parse_vary(arg, where="--vary"):
    """'key=v1,v2,...' -> (key, [values])."""
    if "=" not in arg:
        raise KnobError(f"{where} {arg}: expected KEY=VALUE,VALUE,...")
    key, _, values = arg.partition("=")
    key = key.strip()
    check_key(key, f"{where} {arg}")
    if values.strip() == "":
        raise KnobError(f"{where} {arg}: the list of values for {key} is empty")
    vals = [parse_value(v, f"{where} {arg}") for v in values.split(",")]
    return key, vals


def check_key(key, where):
    parts = key.split(".")
    if not key or any(p == "" for p in parts) or any(not p.replace("_", "").isalnum() for p in parts):
        raise KnobError(f"{where}: {key!r} is not a scene key (dotted names, e.g. firmware.adc_bits)")
    if parts[0] == "effects" and len(parts) != 2:
        raise KnobError(f"{where}: an effect knob is effects.NAME=on,off, got {key!r}")


def load_sweep_file(path):
    """A sweep described in a file: {scene, vary: {key: [values]}, out?,
    repeat?}; the scene and out relative to the file. Returns (scene, [(key,
    values)], out or None, repeat)."""
    where = path
    try:
        with open(path) as f:
            d = yaml.safe_load(f)
    except OSError as e:
        raise KnobError(f"{path}: cannot read ({e.strerror})") from None
    except yaml.YAMLError as e:
        raise KnobError(f"{path}: not YAML ({e})") from None
    if not isinstance(d, dict):
        raise KnobError(f"{path}: a sweep file is a mapping with scene and vary")
    unknown = set(d) - {"scene", "vary", "out", "repeat"}
    if unknown:
        raise KnobError(f"{path}: unknown key {sorted(unknown)[0]!r} (known: out, repeat, scene, vary)")
    base = os.path.dirname(os.path.abspath(path))
    if "scene" not in d or not isinstance(d["scene"], str):
        raise KnobError(f"{path}: scene: the base scene file is missing")
    scene = os.path.normpath(os.path.join(base, d["scene"]))
    vary = d.get("vary")
    if not isinstance(vary, dict) or not vary:
        raise KnobError(f"{path}: vary: a mapping of knobs to lists of values is missing")
    knobs = []
    for key, values in vary.items():
        check_key(str(key), f"{where}: vary.{key}")
        if not isinstance(values, list):
            values = [values]
        if not values:
            raise KnobError(f"{where}: vary.{key}: the list of values is empty")
        for v in values:
            if isinstance(v, (list, dict)) or v is None:
                raise KnobError(f"{where}: vary.{key}: value {v!r} must be one number, word or true/false")
        knobs.append((str(key), values))
    out = d.get("out")
    if out is not None:
        out = os.path.normpath(os.path.join(base, str(out)))
    repeat = d.get("repeat", 1)
    if not isinstance(repeat, int) or repeat < 1:
        raise KnobError(f"{where}: repeat: a whole number >= 1, got {repeat!r}")
    return scene, knobs, out, repeat


def grid(knobs):
    """Every combination: a list of {key: value} in a stable order."""
    keys = [k for k, _ in knobs]
    return [dict(zip(keys, combo)) for combo in itertools.product(*[v for _, v in knobs])]


def _on(value, where):
    if value in (True, "on", "yes"):
        return True
    if value in (False, "off", "no"):
        return False
    raise KnobError(f"{where}: an effect knob takes on or off, got {value!r}")


def apply(scene, settings, where="--vary"):
    """The scene (a dict from the YAML) with the settings applied; a new dict."""
    s = copy.deepcopy(scene)
    for key, value in settings.items():
        parts = key.split(".")
        if parts[0] == "effects":
            effects = list(s.get("effects") or [])
            name = parts[1]
            if _on(value, f"{where} {key}={value}"):
                if name not in effects:
                    effects.append(name)
            else:
                effects = [e for e in effects if e != name]
            s["effects"] = effects
            continue
        node = s
        for p in parts[:-1]:
            if node.get(p) is None:
                node[p] = {}
            if not isinstance(node[p], dict):
                raise KnobError(f"{where} {key}={value}: {p} is not a mapping in the scene")
            node = node[p]
        node[parts[-1]] = value
    return s


def label(settings):
    """A short name of a point: 'adc_bits=10 word_bits=16'."""
    return " ".join(f"{k.split('.')[-1]}={'on' if v is True else 'off' if v is False else v}" for k, v in settings.items())
