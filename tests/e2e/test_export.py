"""A run's data where Python users work (issue 37, sections 5 and 6):
open_run gives a frame per channel with a row per message of the log
(counted here independently, with lcm's own EventLog); ./afm export --csv
writes the same rows; --mcap writes a file that the mcap library reads back
with every channel's count equal to the log's, every message valid against
its schema, the frames as foxglove.CompressedImage and the scans as
foxglove.Grid; the GSF reader's orientation (row 0 at +y) holds against the
scan lines in the log and the particles of the scene; the GSF files carry
the run's metadata and the lateral channel; bad inputs exit 2 with one
line. And, without a run, the schema generator on every lcmtypes/*.lcm
against lcm-gen's classes (the parser alone: tests/py/test_lcmschema.py)."""
import base64
import collections
import glob
import json
import os
import shutil
import subprocess
import sys
import unittest

import jsonschema
import lcm
import numpy as np
import yaml
from mcap.reader import make_reader

import e2e_support
from analysis import afmlog, gsf, lcmschema, open_run, runs

EXPORT = [sys.executable, "-m", "analysis.export"]
LCM_FILES = sorted(glob.glob(os.path.join(e2e_support.SRC, "lcmtypes", "*.lcm")))


def export(*args):
    p = subprocess.run([*EXPORT, *args], capture_output=True, text=True, timeout=300)
    return p.returncode, p.stdout, p.stderr


def log_events(path):
    """{channel: [log timestamp us, ...]} read by lcm's EventLog alone."""
    out = collections.defaultdict(list)
    for ev in lcm.EventLog(path, "r"):
        out[ev.channel].append(ev.timestamp)
    return out


def validator(schema_bytes):
    schema = json.loads(schema_bytes)
    jsonschema.Draft202012Validator.check_schema(schema)
    return jsonschema.Draft202012Validator(schema)


def scan_from_log(log_msgs, header, field):
    """A scan's grid rebuilt from its AFM_SCAN_LINE messages (its req_id and
    size), row 0 at the top as the renderer keeps it: {field}[line] goes to
    row ny - 1 - line."""
    nx, ny = int(header["XRes"]), int(header["YRes"])
    grid = np.full((ny, nx), np.nan)
    for m in log_msgs:
        if m.req_id == int(header["ScanRequest"]) and m.n == nx and m.n_lines == ny:
            grid[ny - 1 - m.line] = getattr(m, field)
    return grid


class SchemaGenerator(unittest.TestCase):
    """Every .lcm file: its schema is a valid JSON Schema with every field of
    the type lcm-gen generated, a default message of that type validates, and
    a message with a field missing or of the wrong type does not."""

    def test_every_lcm_file(self):
        self.assertGreater(len(LCM_FILES), 10)
        known = lcmschema.types()
        for path in LCM_FILES:
            name = os.path.basename(path)[:-4]
            with self.subTest(type=name):
                s = lcmschema.parse(path)
                self.assertEqual(s.name, name)
                cls = getattr(afmlog.afm, name)
                self.assertEqual([f.name for f in s.fields], list(cls.__slots__), "every field lcm-gen knows, in order")
                schema = lcmschema.json_schema(name, known)
                v = validator(json.dumps(schema))
                self.assertEqual(set(schema["properties"]), set(cls.__slots__))
                msg = lcmschema.to_json(cls(), name, known)
                self.assertEqual(list(v.iter_errors(msg)), [])
                bad = dict(msg)
                del bad[s.fields[-1].name]
                self.assertFalse(v.is_valid(bad), "a missing field is refused")
                bad = dict(msg, **{s.fields[0].name: "text" if s.fields[0].type != "string" else 1})
                self.assertFalse(v.is_valid(bad), "a wrong type is refused")
                for f in s.fields:
                    if f.unit:
                        self.assertTrue(f.column.lower().endswith(f.unit.lower()), f"{name}.{f.name}: {f.column} carries {f.unit}")
                        self.assertTrue(any(w in f.comment.split(", ") or f", {w}" in f.comment
                                            for w, u in lcmschema.UNIT_WORDS.items() if u == f.unit),
                                        f"{name}.{f.name}: the unit {f.unit} is in its comment")


class Export(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.out = e2e_support.tmpdir("export-run")
        code, _, err, cls.rj = e2e_support.run(e2e_support.scene("short.yaml"), cls.out)
        assert code == 0, err
        cls.log = os.path.join(cls.out, "bus.lcmlog")
        cls.events = log_events(cls.log)
        cls.scene = yaml.safe_load(open(os.path.join(cls.out, "scene.yaml")))
        cls.data = open_run(cls.out)
        cls.csv = os.path.join(cls.out, "csv")
        cls.mcap = os.path.join(cls.out, "run.mcap")
        cls.export = export(cls.out, "--csv", cls.csv, "--mcap", cls.mcap)

    @classmethod
    def tearDownClass(cls):
        e2e_support.cleanup(cls.out)

    def test_the_log_has_only_the_bus_channels(self):
        # so that comparing the known channels' counts compares every message
        self.assertEqual(sorted(set(self.events) - set(afmlog.CHANNELS)), [])
        self.assertGreater(sum(map(len, self.events.values())), 1000)

    def test_open_run_has_a_row_per_message(self):
        self.assertEqual(sorted(self.data.frames), sorted(self.events))
        for ch, times in self.events.items():
            df = self.data[ch]
            self.assertEqual(len(df), len(times), ch)
            self.assertEqual(df["log_time_us"].tolist(), times, ch)
        self.assertEqual(self.data.info["channels"], {ch: len(t) for ch, t in self.events.items()}, "run.json, as a dict")

    def test_columns_carry_units_and_the_messages_values(self):
        fw = self.data["FW_STATE"]
        msgs = self.data.messages("FW_STATE")
        for f in lcmschema.types()["fw_state_t"].fields:
            if f.primitive and f.fixed and f.dims:
                for i, c in enumerate(f.components):
                    col = f"{f.column}_{c}"
                    self.assertIn(col, fw.columns)
                    self.assertEqual(fw[col].tolist(), [getattr(m, f.name)[i] for m in msgs], col)
            elif f.primitive and not f.dims:
                self.assertEqual(fw[f.column].tolist(), [getattr(m, f.name) for m in msgs], f.column)
        self.assertIn("utime_us", fw.columns)                       # the comment says microseconds
        self.assertFalse(any(c.startswith("objects") for c in fw.columns), "nested messages are left out")
        samples = self.data.samples()
        self.assertEqual(len(samples), sum(m.n for m in self.data.messages("AFM_ANALOG")))
        particles = self.data.particles("SIM_TRUTH")
        self.assertEqual(set(particles["id"]), {p["id"] for p in self.scene["objects"]["particles"]})

    def test_csv_has_the_same_rows(self):
        import pandas as pd
        self.assertEqual(self.export[0], 0, self.export[2])
        files = sorted(os.path.basename(p)[:-4] for p in glob.glob(os.path.join(self.csv, "*.csv")))
        self.assertEqual(files, sorted(self.events))
        for ch, times in self.events.items():
            df = pd.read_csv(os.path.join(self.csv, ch + ".csv"))
            self.assertEqual(len(df), len(times), ch)
            self.assertEqual(list(df.columns), list(self.data[ch].columns), ch)

    def read_mcap(self):
        self.assertEqual(self.export[0], 0, self.export[2])
        out = collections.defaultdict(list)
        validators = {}
        with open(self.mcap, "rb") as f:
            reader = make_reader(f)
            for schema, channel, message in reader.iter_messages(log_time_order=False):
                if schema.id not in validators:
                    self.assertEqual(schema.encoding, "jsonschema")
                    validators[schema.id] = (schema.name, validator(schema.data))
                out[channel.topic].append((message.log_time, validators[schema.id], json.loads(message.data)))
            meta = {m.name: m.metadata for m in reader.iter_metadata()}
        return out, meta

    def test_mcap_round_trips(self):
        topics, meta = self.read_mcap()
        for ch, times in self.events.items():
            got = topics.get(ch, [])
            self.assertEqual(len(got), len(times), ch)
            self.assertEqual([t for t, _, _ in got], [t * 1000 for t in times], f"{ch}: log time = the LCM log's")
            self.assertEqual(got[0][1][0], "afm." + afmlog.CHANNELS[ch])
        checked = 0
        for topic, msgs in topics.items():
            for _, (name, v), m in msgs:
                errors = list(v.iter_errors(m))
                self.assertEqual(errors, [], f"{topic} ({name})")
                checked += 1
        self.assertEqual(checked, sum(map(len, topics.values())))
        # the validators are live: a message broken on purpose fails
        _, (_, v), m = topics["FW_STATE"][0]
        self.assertFalse(v.is_valid(dict(m, force_nN=[1.0, 2.0])))
        # the nested objects are there, whole as sent
        fw0 = self.data.messages("FW_STATE")[0]
        self.assertEqual(len(topics["FW_STATE"][0][2]["objects"]["particles"]), fw0.objects.n_particles)
        self.assertEqual(json.loads(meta["run"]["run.json"])["scene_hash"], self.rj["scene_hash"])

    def test_mcap_frames_and_scans(self):
        topics, _ = self.read_mcap()
        pngs = sorted(glob.glob(os.path.join(self.out, "frames", "*.png")))
        frames = topics["/frames"]
        self.assertEqual(len(frames), len(pngs))
        self.assertEqual(len(frames), self.rj["frames"])
        self.assertEqual(frames[0][1][0], "foxglove.CompressedImage")
        self.assertEqual(base64.b64decode(frames[-1][2]["data"]), open(pngs[-1], "rb").read())
        rf = self.events["RENDER_FRAME"]
        self.assertEqual(frames[0][0], rf[0] * 1000, "a frame is logged when its RENDER_FRAME was")
        gsfs = {os.path.basename(p)[:-4]: p for p in glob.glob(os.path.join(self.out, "*.gsf"))}
        self.assertEqual({t[len("/scans/"):] for t in topics if t.startswith("/scans/")}, set(gsfs))
        for name, path in gsfs.items():
            (_, (schema, _), grid), = topics["/scans/" + name]
            self.assertEqual(schema, "foxglove.Grid")
            header, z = gsf.read(path)
            data = np.frombuffer(base64.b64decode(grid["data"]), dtype="<f4").reshape(z.shape)
            np.testing.assert_array_equal(data, np.flipud(z), "Grid rows from -y up")
            self.assertAlmostEqual(grid["pose"]["position"]["y"], float(header["YOffset"]))

    def test_gsf_orientation_against_the_scan_lines(self):
        lines = self.data.messages("AFM_SCAN_LINE")
        scans = [n for n in self.data.scans if n.startswith("scan_") and not n.endswith("_lateral")]
        self.assertGreaterEqual(len(scans), 3, scans)   # initial, final, a local scan
        for name in scans:
            header, z = self.data.scans[name]
            self.assertEqual(z.dtype, np.float32)
            self.assertEqual(z.shape, (int(header["YRes"]), int(header["XRes"])))
            np.testing.assert_allclose(z, scan_from_log(lines, header, "height_nm") * 1e-9, rtol=1e-6, atol=1e-15, err_msg=name)
            lh, lat = self.data.scans[name + "_lateral"]
            self.assertEqual((lh["Channel"], lh["ZUnits"]), ("Lateral", "V"))
            np.testing.assert_allclose(lat, scan_from_log(lines, header, "lat_v"), rtol=1e-6, atol=1e-7, err_msg=name)
            self.assertGreater(float(np.abs(lat).max()), 0.0, f"{name}: a lateral signal")
            _, ys = gsf.axes(header)
            first = min((m for m in lines if m.req_id == int(header["ScanRequest"]) and m.line == 0), key=lambda m: m.utime)
            self.assertAlmostEqual(ys[-1] * 1e9, first.y_nm, delta=1e-3, msg="the last row is line 0, the lowest y")

    def test_gsf_orientation_against_the_scene(self):
        # each particle's top in scan_initial where the scene put it, and not
        # at its mirror image across the field's centre line y = 0
        header, z = gsf.read(os.path.join(self.out, "scan_initial.gsf"))
        xs, ys = gsf.axes(header)
        base = float(np.median(z))
        for p in self.scene["objects"]["particles"]:
            c = int(np.argmin(np.abs(xs * 1e9 - p["x_nm"])))
            r = int(np.argmin(np.abs(ys * 1e9 - p["y_nm"])))
            rm = int(np.argmin(np.abs(ys * 1e9 + p["y_nm"])))
            self.assertAlmostEqual((z[r, c] - base) * 1e9, 2 * p["radius_nm"], delta=0.1 * p["radius_nm"], msg=p)
            self.assertLess((z[rm, c] - base) * 1e9, 0.2 * p["radius_nm"], msg=f"mirror of {p}")

    def test_gsf_metadata(self):
        op = self.scene["operator"]
        for name, (h, _) in self.data.scans.items():
            with self.subTest(file=name):
                self.assertEqual(h["Scene"], self.scene["name"])
                self.assertEqual(float(h["Load_nN"]), op["load_nN"])
                self.assertEqual(float(h["SetPoint_nN"]), op.get("scan_load_nN", op["load_nN"]))
                self.assertAlmostEqual(float(h["ScanAngle_deg"]), self.rj["card"]["scan_angle_mdeg"] / 1000, places=3)
                self.assertRegex(h["Date"], r"^\d{4}-\d\d-\d\dT\d\d:\d\d:\d\dZ$")
                self.assertIn(h["Channel"], ("Height", "Lateral"))
                self.assertTrue("ScanRequest" in h or "Frame" in h)
        local = self.data.scans["scan_local_1"][0]
        self.assertAlmostEqual(float(local["SimTime_s"]), op["local_scans"][0]["at_s"], delta=1.5 / self.scene["frame_rate_hz"])
        final = self.data.scans["display_final"][0]
        self.assertAlmostEqual(float(final["SimTime_s"]), self.scene["duration_s"], delta=1.5 / self.scene["frame_rate_hz"])

    def test_bad_inputs_exit_2_with_one_line(self):
        tmp = e2e_support.tmpdir("export-bad")
        self.addCleanup(e2e_support.cleanup, tmp)
        cut = os.path.join(tmp, "cut")
        os.makedirs(cut)
        shutil.copy(os.path.join(self.out, "run.json"), cut)
        blob = open(self.log, "rb").read()
        with open(os.path.join(cut, "bus.lcmlog"), "wb") as f:
            f.write(blob[:len(blob) // 2])
        cases = [
            ([os.path.join(tmp, "missing"), "--csv", os.path.join(tmp, "c")], os.path.join(tmp, "missing")),
            ([tmp, "--csv", os.path.join(tmp, "c")], os.path.join(tmp, "bus.lcmlog")),
            ([cut, "--mcap", os.path.join(tmp, "m.mcap")], os.path.join(cut, "bus.lcmlog")),
            ([self.out], "--csv"),
        ]
        for args, named in cases:
            with self.subTest(args=args):
                code, so, se = export(*args)
                self.assertEqual(code, 2, so + se)
                lines = [l for l in se.splitlines() if l.strip()]
                self.assertEqual(len(lines), 1, se)
                self.assertIn(named, lines[0])
        self.assertIn("truncated", export(cut, "--csv", os.path.join(tmp, "c"))[2])
        self.assertFalse(os.path.exists(os.path.join(tmp, "m.mcap")), "nothing written from a bad log")
        with self.assertRaises(runs.RunError):
            open_run(tmp)
        with self.assertRaises(afmlog.LogError):
            open_run(cut)

    def test_help_needs_no_build(self):
        p = subprocess.run([os.path.join(e2e_support.SRC, "afm"), "export", "--help"], capture_output=True, text=True, timeout=60)
        self.assertEqual(p.returncode, 0, p.stderr)
        self.assertIn("--mcap FILE", p.stdout)
        self.assertNotIn("building", p.stderr)


if __name__ == "__main__":
    e2e_support.main()
