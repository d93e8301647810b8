"""analysis.knobs: a knob's syntax, the sweep file, the grid of points and
a point's scene. Every refusal names where the knob came from and the value."""
import os

import pytest

from analysis import knobs
from analysis.knobs import KnobError


def test_a_vary_argument_is_a_key_and_its_values_as_yaml_scalars():
    assert knobs.parse_vary("firmware.adc_bits=10,12") == ("firmware.adc_bits", [10, 12])
    assert knobs.parse_vary(" outputs.update_mode = local, full") == ("outputs.update_mode", ["local", "full"])
    assert knobs.parse_vary("sample_rate_hz=1.5,2.0e+5") == ("sample_rate_hz", [1.5, 2e5])
    # YAML 1.1 (PyYAML): an exponent without a dot is a word, which the
    # scene's validator then refuses naming the value
    assert knobs.parse_vary("sample_rate_hz=2e5") == ("sample_rate_hz", ["2e5"])
    assert knobs.parse_vary("firmware.compensate=true,false") == ("firmware.compensate", [True, False])
    assert knobs.parse_vary("effects.drift=on,off") == ("effects.drift", [True, False])   # YAML 1.1 booleans


@pytest.mark.parametrize("arg, needle", [
    ("firmware.adc_bits", "expected KEY=VALUE,VALUE,..."),
    ("firmware.adc_bits=", "the list of values for firmware.adc_bits is empty"),
    ("firmware.adc_bits=10,,12", "an empty value in the list"),
    ("firmware.adc_bits=[1,2]", "is not a YAML scalar"),
    ("firmware.adc_bits=~", "must be one number, word or true/false"),
    ("firmware..adc_bits=10", "is not a scene key"),
    ("firmware.adc-bits=10", "is not a scene key"),
    ("=10", "is not a scene key"),
    ("effects=on", "an effect knob is effects.NAME=on,off, got 'effects'"),
    ("effects.a.b=on", "an effect knob is effects.NAME=on,off"),
])
def test_a_bad_vary_argument_is_refused_naming_it(arg, needle):
    with pytest.raises(KnobError) as e:
        knobs.parse_vary(arg)
    assert str(e.value).startswith(f"--vary {arg}"), str(e.value)
    assert needle in str(e.value)


def write(tmp_path, text, name="sweep.yaml"):
    path = tmp_path / name
    path.write_text(text)
    return str(path)


def test_a_sweep_file_resolves_its_scene_and_out_from_its_folder(tmp_path):
    path = write(tmp_path, "scene: ../scenes/default.yaml\nvary:\n  firmware.adc_bits: [10, 12]\n"
                           "  block_hz: 1000\nout: runs/x\nrepeat: 3\n")
    scene, ks, out, repeat = knobs.load_sweep_file(path)
    assert scene == os.path.normpath(str(tmp_path / ".." / "scenes" / "default.yaml"))
    assert ks == [("firmware.adc_bits", [10, 12]), ("block_hz", [1000])]   # a lone value is a list of one
    assert out == str(tmp_path / "runs" / "x")
    assert repeat == 3


def test_the_committed_sweep_files_read():
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    for name in ("firmware.yaml", "loop.yaml"):
        scene, ks, out, repeat = knobs.load_sweep_file(os.path.join(root, "sweeps", name))
        assert os.path.exists(scene), scene
        assert ks and repeat == 1 and out


@pytest.mark.parametrize("text, needle", [
    ("- a\n- b\n", "a sweep file is a mapping with scene and vary"),
    ("scene: s.yaml\nvary: {k: [1]}\nworkers: 3\n", "unknown key 'workers' (known: out, repeat, scene, vary)"),
    ("vary: {k: [1]}\n", "scene: the base scene file is missing"),
    ("scene: s.yaml\n", "vary: a mapping of knobs to lists of values is missing"),
    ("scene: s.yaml\nvary: {}\n", "vary: a mapping of knobs to lists of values is missing"),
    ("scene: s.yaml\nvary: {k: []}\n", "vary.k: the list of values is empty"),
    ("scene: s.yaml\nvary: {k: [[1, 2]]}\n", "vary.k: value [1, 2] must be one number, word or true/false"),
    ("scene: s.yaml\nvary: {a..b: [1]}\n", "vary.a..b: 'a..b' is not a scene key"),
    ("scene: s.yaml\nvary: {k: [1]}\nrepeat: 0\n", "repeat: a whole number >= 1, got 0"),
    ("scene: s.yaml\nvary: {k: [1]}\nrepeat: two\n", "repeat: a whole number >= 1, got 'two'"),
    ("scene: [\n", "not YAML"),
])
def test_a_bad_sweep_file_is_refused_naming_the_file_and_key(tmp_path, text, needle):
    path = write(tmp_path, text)
    with pytest.raises(KnobError) as e:
        knobs.load_sweep_file(path)
    assert str(e.value).startswith(path + ": "), str(e.value)
    assert needle in str(e.value)


def test_a_missing_sweep_file_is_named(tmp_path):
    path = str(tmp_path / "none.yaml")
    with pytest.raises(KnobError, match="none.yaml: cannot read"):
        knobs.load_sweep_file(path)


def test_the_grid_is_every_combination_in_a_stable_order():
    g = knobs.grid([("a", [1, 2]), ("b", ["x", "y", "z"])])
    assert g == [{"a": 1, "b": "x"}, {"a": 1, "b": "y"}, {"a": 1, "b": "z"},
                 {"a": 2, "b": "x"}, {"a": 2, "b": "y"}, {"a": 2, "b": "z"}]
    assert knobs.grid([("a", [1])]) == [{"a": 1}]


def test_apply_sets_nested_keys_on_a_copy():
    scene = {"firmware": {"adc_bits": 16}, "effects": ["drift"]}
    s = knobs.apply(scene, {"firmware.adc_bits": 10, "sample.wire.segments": 8, "block_hz": 500})
    assert s == {"firmware": {"adc_bits": 10}, "effects": ["drift"], "sample": {"wire": {"segments": 8}}, "block_hz": 500}
    assert scene == {"firmware": {"adc_bits": 16}, "effects": ["drift"]}, "the base scene is not changed"


def test_an_effect_knob_lists_the_effect_or_not():
    scene = {"effects": ["drift"]}
    assert knobs.apply(scene, {"effects.noise": "on"})["effects"] == ["drift", "noise"]
    assert knobs.apply(scene, {"effects.drift": True})["effects"] == ["drift"]   # not twice
    assert knobs.apply(scene, {"effects.drift": "off"})["effects"] == []
    assert knobs.apply({}, {"effects.drift": False})["effects"] == []
    with pytest.raises(KnobError, match=r"--vary effects.drift=maybe: an effect knob takes on or off, got 'maybe'"):
        knobs.apply(scene, {"effects.drift": "maybe"})


def test_apply_refuses_a_path_through_a_value():
    with pytest.raises(KnobError, match=r"--vary firmware.adc_bits.x=1: adc_bits is not a mapping in the scene"):
        knobs.apply({"firmware": {"adc_bits": 16}}, {"firmware.adc_bits.x": 1})


def test_a_points_label_names_the_last_part_of_each_key():
    assert knobs.label({"firmware.adc_bits": 10, "firmware.compensate": True, "effects.drift": False}) == \
        "adc_bits=10 compensate=on drift=off"
