"""A run's data where Python users work (issue 37, sections 5 and 6; issue
50, items 4 and 5): open_run gives a frame per channel with a row per
message of the log (counted here independently, with lcm's own EventLog);
./afm export --csv writes the same rows; --mcap writes a file that the mcap
library reads back with every channel's count equal to the log's, every
message on its simulated time (within one block of the run's) and valid
against its schema: the bus's JSON against the JSON Schema, the tip, the
objects, the lever and the force (SceneUpdate, PoseInFrame, FrameTransform),
the frames (CompressedImage) and the scans (Grid) parsed by the classes of
Foxglove's own package (foxglove-schemas-protobuf), whose descriptors the
file carries; a Foxglove layout beside it names topics the file has; --gwy
writes one .gwy whose channels gwyfile and Gwyddion itself read back as the
GSF files' values with their metadata; the GSF reader's orientation (row 0 at +y) holds against the
scan lines in the log and the particles of the scene; the GSF files carry
the run's metadata and the lateral channel; bad inputs exit 2 with one
line. And, without a run, the schema generator on every lcmtypes/*.lcm
against lcm-gen's classes (the parser alone: tests/py/test_lcmschema.py)."""
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
from google.protobuf import descriptor_pb2
from mcap.reader import make_reader

import e2e_support
from analysis import afmlog, export as export_mod, foxglove, gsf, lcmschema, open_run, runs

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


FOXGLOVE = {cls.DESCRIPTOR.full_name: cls for cls in foxglove.CLASSES}


def foxglove_parser(schema):
    """The parse of a protobuf topic: the class of Foxglove's package named
    by the schema, once the file's FileDescriptorSet is found to hold that
    package's own descriptor of it (not a copy written elsewhere)."""
    cls = FOXGLOVE[schema.name]
    fds = descriptor_pb2.FileDescriptorSet.FromString(schema.data)
    mine = {f.name: f for f in fds.file}
    theirs = descriptor_pb2.FileDescriptorProto()
    cls.DESCRIPTOR.file.CopyToProto(theirs)
    assert mine[theirs.name] == theirs, schema.name
    for dep in cls.DESCRIPTOR.file.dependencies:
        assert dep.name in mine, (schema.name, dep.name)

    def parse(data):
        m = cls.FromString(data)
        assert m.SerializeToString() == data, schema.name   # every byte read as a field of the schema
        return m
    return schema.name, parse


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
                col = runs.column_name(f.column)   # flags is flag_bits: DataFrame.flags would hide it
                self.assertEqual(fw[col].tolist(), [getattr(m, f.name) for m in msgs], col)
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
        """({topic: [(log time, (schema name, validator or parse), message)]}, metadata), read once."""
        self.assertEqual(self.export[0], 0, self.export[2])
        if not hasattr(type(self), "_mcap"):
            type(self)._mcap = self._read_mcap()
        return type(self)._mcap

    def _read_mcap(self):
        out = collections.defaultdict(list)
        validators = {}
        with open(self.mcap, "rb") as f:
            reader = make_reader(f)
            for schema, channel, message in reader.iter_messages(log_time_order=False):
                if schema.id not in validators:
                    self.assertIn(schema.encoding, ("jsonschema", "protobuf"))
                    validators[schema.id] = (foxglove_parser(schema) if schema.encoding == "protobuf"
                                             else (schema.name, validator(schema.data)))
                self.assertEqual(message.publish_time, message.log_time)
                name, v = validators[schema.id]
                body = v(message.data) if schema.encoding == "protobuf" else json.loads(message.data)
                out[channel.topic].append((message.log_time, validators[schema.id], body))
            meta = {m.name: m.metadata for m in reader.iter_metadata()}
        return out, meta

    def test_mcap_round_trips(self):
        topics, meta = self.read_mcap()
        for ch, times in self.events.items():
            got = topics.get(ch, [])
            self.assertEqual(len(got), len(times), ch)
            self.assertEqual(sorted(m[export_mod.WALL_FIELD] for _, _, m in got), sorted(times),
                             f"{ch}: the LCM log's wall-clock time kept as a field")
            self.assertEqual(got[0][1][0], "afm." + afmlog.CHANNELS[ch])
        checked = 0
        for topic, msgs in topics.items():
            for _, (name, v), m in msgs:
                if hasattr(v, "iter_errors"):
                    self.assertEqual(list(v.iter_errors(m)), [], f"{topic} ({name})")
                checked += 1   # a protobuf message was parsed whole by Foxglove's class when read
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
        self.assertEqual(frames[-1][2].data, open(pngs[-1], "rb").read())
        rf = self.data.messages("RENDER_FRAME")
        self.assertEqual(frames[0][0], rf[0].utime * 1000, "a frame is logged at its RENDER_FRAME's simulated time")
        self.assertEqual(frames[0][2].timestamp.ToNanoseconds(), rf[0].utime * 1000)
        gsfs = {os.path.basename(p)[:-4]: p for p in glob.glob(os.path.join(self.out, "*.gsf"))}
        self.assertEqual({t[len("/scans/"):] for t in topics if t.startswith("/scans/")}, set(gsfs))
        for name, path in gsfs.items():
            (t, (schema, _), grid), = topics["/scans/" + name]
            self.assertEqual(schema, "foxglove.Grid")
            header, z = gsf.read(path)
            self.assertEqual(t, round(float(header["SimTime_s"]) * 1e9), "a scan at its simulated time")
            data = np.frombuffer(grid.data, dtype="<f4").reshape(z.shape)
            np.testing.assert_array_equal(data, np.flipud(z), "Grid rows from -y up")
            self.assertAlmostEqual(grid.pose.position.y, float(header["YOffset"]))

    def test_mcap_is_on_simulated_time(self):
        # every message within one block of the run's simulated time, in
        # order; each message with a simulated time of its own logged at it
        # (the wall clock, before: a 3 s run spanned 0.22-0.94 s)
        block_ns = 1e9 / self.scene["block_hz"]
        duration_ns = self.scene["duration_s"] * 1e9
        with open(self.mcap, "rb") as f:
            times = [m.log_time for _, _, m in make_reader(f).iter_messages(log_time_order=False)]
        self.assertEqual(times, sorted(times), "written in simulated-time order")
        self.assertGreaterEqual(times[0], 0)
        self.assertLessEqual(times[-1], duration_ns + block_ns)
        self.assertGreaterEqual(times[-1], duration_ns - block_ns, "the run's end is there")
        topics, _ = self.read_mcap()
        for ch in ("AFM_ANALOG", "FW_STATE", "SIM_TRUTH", "HAPTIC_FORCE", "AFM_SCAN_LINE", "RENDER_FRAME"):
            got = sorted((m[export_mod.WALL_FIELD], t) for t, _, m in topics[ch])
            want = sorted((t, m.utime * 1000) for t, m in zip(self.data[ch]["log_time_us"], self.data.messages(ch)))
            self.assertEqual(got, want, ch)
        for t, _, m in topics["AFM_HEARTBEAT"]:
            if m["sim_utime"] >= 0:
                self.assertEqual(t, m["sim_utime"] * 1000)
        clock = export_mod._block_clock(self.data)
        for t, _, m in topics["AFM_SCAN_REQ"]:   # its utime is the wall clock: the block in progress's
            self.assertLessEqual(t, duration_ns + block_ns)
            i = int(np.searchsorted(clock[0], m[export_mod.WALL_FIELD], "right")) - 1
            self.assertEqual(t, (int(clock[1][i]) if i >= 0 else 0) * 1000)

    def test_mcap_tip_objects_lever_and_force_as_foxglove_types(self):
        topics, _ = self.read_mcap()
        fw, truth = self.data.messages("FW_STATE"), self.data.messages("SIM_TRUTH")
        for topic, n in (("/scene/card", len(fw)), ("/scene/truth", len(truth)), ("/tip", len(fw)),
                         ("/truth/tip", len(truth)), ("/tf", len(fw) + len(truth))):
            self.assertEqual(len(topics[topic]), n, topic)
        self.assertEqual({n for _, (n, _), _ in topics["/scene/truth"]}, {"foxglove.SceneUpdate"})
        self.assertEqual({n for _, (n, _), _ in topics["/tf"]}, {"foxglove.FrameTransform"})
        self.assertEqual({n for _, (n, _), _ in topics["/tip"]}, {"foxglove.PoseInFrame"})
        # the truth's first state: a sphere of each scene particle's radius at its place, the apex, the lever, the force
        t, _, first = topics["/scene/truth"][0]
        (e,) = first.entities
        self.assertEqual((e.id, e.frame_id, e.timestamp.ToNanoseconds()), ("truth", "afm", t))
        m0 = truth[0]
        self.assertEqual(t, m0.utime * 1000)
        spheres = {(round(s.pose.position.x * 1e9, 3), round(s.pose.position.y * 1e9, 3)): s.size.x * 1e9 / 2 for s in e.spheres}
        for p in self.scene["objects"]["particles"]:
            self.assertAlmostEqual(spheres[(p["x_nm"], p["y_nm"])], p["radius_nm"], places=6, msg=p)
        self.assertEqual(len(e.spheres), len(self.scene["objects"]["particles"]) + 1, "the particles and the apex")
        (lever,) = e.cubes
        lever_um = self.scene.get("probe", {}).get("lever_length_um", 100)   # the scene's, else the paper probe's 100 um
        self.assertEqual(export_mod._probe(self.data), (lever_um, self.scene.get("probe", {}).get("tip_height_um", 17.3)))
        self.assertAlmostEqual(lever.size.x, lever_um * 1e-6)
        tips = [s for s in e.spheres if abs(s.pose.position.x * 1e9 - m0.tip_nm[0]) < 1e-6]
        self.assertTrue(tips, "the apex where the truth has it")
        fmag = float(np.linalg.norm(m0.force_nN))
        self.assertEqual(len(e.arrows), 1 if fmag > 0 else 0)
        if e.arrows:
            self.assertAlmostEqual((e.arrows[0].shaft_length + e.arrows[0].head_length) / foxglove.ARROW_M_PER_NN, fmag, places=6)
        _, _, tf = topics["/tf"][0]
        self.assertEqual(tf.parent_frame_id, "afm")
        pose = topics["/tip"][-1][2]
        self.assertAlmostEqual(pose.pose.position.x * 1e9, fw[-1].tip_nm[0], places=6)

    def test_mcap_has_a_foxglove_layout_of_its_topics(self):
        topics, _ = self.read_mcap()
        layout = json.load(open(export_mod.layout_path(self.mcap)))
        self.assertIn("layout", layout)
        panels = layout["configById"]
        self.assertEqual(panels["Image!frames"]["imageMode"]["imageTopic"], "/frames")
        named = set(panels["3D!afm"]["topics"]) | {p["value"].split(".")[0] for k, c in panels.items() if k.startswith("Plot!")
                                                     for p in c["paths"]}
        self.assertEqual(sorted(named - set(topics)), [], "every topic the layout shows is in the file")

    def test_gwy_has_the_scans_as_channels_with_metadata(self):
        import gwyfile
        gwy = os.path.join(self.out, "run.gwy")
        code, so, se = export(self.out, "--gwy", gwy)
        self.assertEqual(code, 0, se)
        gsfs = {os.path.basename(p)[:-4]: p for p in glob.glob(os.path.join(self.out, "*.gsf"))}
        for k in ("scan_initial", "scan_initial_lateral", "scan_final", "scan_final_lateral", "display_final"):
            self.assertIn(k, gsfs)
        readers = [("gwyfile", gwy)]
        if shutil.which("gwyddion"):   # Gwyddion's own reader: it reads the file and writes what it read
            again = os.path.join(self.out, "gwyddion.gwy")
            p = subprocess.run(["gwyddion", "--no-log-to-file", f"--convert-to-gwy={again}", gwy], capture_output=True,
                               text=True, timeout=120, env=dict(os.environ, DISPLAY=""))
            self.assertEqual(p.returncode, 0, p.stderr)
            readers.append(("gwyddion", again))
        for who, path in readers:
            c = gwyfile.load(path)
            titles = {c[f"/{i}/data/title"]: i for i in range(len(gsfs))}
            self.assertEqual(set(titles), set(gsfs), who)
            self.assertEqual([t for t, _ in sorted(titles.items(), key=lambda kv: kv[1])][:3],
                             ["scan_initial", "scan_initial_lateral", "scan_final"], who)
            for name, i in titles.items():
                with self.subTest(reader=who, channel=name):
                    header, z = gsf.read(gsfs[name])
                    field = c[f"/{i}/data"]
                    np.testing.assert_allclose(field.data, z, rtol=1e-7, atol=0)
                    self.assertAlmostEqual(field["xreal"], float(header["XReal"]))
                    self.assertAlmostEqual(field.get("yoff", 0.0), float(header["YOffset"]))
                    self.assertEqual(field["si_unit_z"]["unitstr"], header["ZUnits"])
                    meta = dict(c[f"/{i}/meta"])
                    for k in ("Scene", "Load_nN", "SetPoint_nN", "ScanAngle_deg", "SimTime_s", "Date", "Channel"):
                        self.assertEqual(meta[k], header[k], k)
                    self.assertEqual(meta["Run_scene_hash"], self.rj["scene_hash"])
        empty = e2e_support.tmpdir("export-nogsf")
        self.addCleanup(e2e_support.cleanup, empty)
        for f in ("bus.lcmlog", "run.json"):
            shutil.copy(os.path.join(self.out, f), empty)
        code, _, se = export(empty, "--gwy", os.path.join(empty, "x.gwy"))
        self.assertEqual((code, len(se.strip().splitlines())), (2, 1), se)
        self.assertIn("no GSF file", se)

    def test_scene_from_the_runs_scan(self):
        # the bench's own scan (tip convolution and noise on): each scene
        # particle found within 2 nm in x, y and radius, nothing else found,
        # and the scene written is one the launcher accepts
        self.assertIn("tip_convolution", self.scene["effects"])
        out = os.path.join(self.out, "from_scan", "scene.yaml")
        os.makedirs(os.path.dirname(out), exist_ok=True)
        p = subprocess.run([sys.executable, "-m", "analysis.from_scan", os.path.join(self.out, "scan_initial.gsf"), "--out", out],
                           capture_output=True, text=True, timeout=120)
        self.assertEqual(p.returncode, 0, p.stderr)
        got = yaml.safe_load(open(out))
        found = got["objects"]["particles"]
        truth = self.scene["objects"]["particles"]
        self.assertEqual(len(found), len(truth), found)
        self.assertNotIn("wires", got["objects"])
        for t in truth:
            f = min(found, key=lambda f: (f["x_nm"] - t["x_nm"]) ** 2 + (f["y_nm"] - t["y_nm"]) ** 2)
            for k in ("x_nm", "y_nm", "radius_nm"):
                self.assertAlmostEqual(f[k], t[k], delta=2.0, msg=(k, t, f))
        sub_header, sub = gsf.read(os.path.join(os.path.dirname(out), got["sample"]["substrate"]["gsf"]))
        self.assertLess(float(np.abs(sub).max()) * 1e9, 2.0, "the substrate: levelled, the particles out")
        c = subprocess.run([e2e_support.paths.LAUNCH, "--check", "--scene", out], capture_output=True, text=True, timeout=60)
        self.assertEqual(c.returncode, 0, c.stderr)
        bad = os.path.join(self.out, "from_scan", "lateral.yaml")
        p = subprocess.run([sys.executable, "-m", "analysis.from_scan", os.path.join(self.out, "scan_initial_lateral.gsf"),
                            "--out", bad], capture_output=True, text=True, timeout=60)
        self.assertEqual((p.returncode, len(p.stderr.strip().splitlines())), (2, 1), p.stderr)
        self.assertIn("not a height scan", p.stderr)

    def test_scene_from_a_scan_with_scan_artefacts(self):
        # the same scene, its scans with line offsets (0.5 nm rms) and the
        # scanner's bow (2 nm) besides the tip's convolution and the noise
        scene = dict(self.scene, duration_s=0.1, effects=self.scene["effects"] + ["scan_artefacts"],
                     afm={"scan_artefacts": {"line_offset_rms_nm": 0.5, "servo_lag_nm": 0, "bow_sag_nm": 2}},
                     operator=dict(self.scene["operator"], local_scans=[]))
        tmp = e2e_support.tmpdir("export-artefacts")
        self.addCleanup(e2e_support.cleanup, tmp)
        path, run = os.path.join(tmp, "scene.yaml"), os.path.join(tmp, "run")
        with open(path, "w") as f:
            yaml.safe_dump(scene, f)
        code, _, err, _ = e2e_support.run(path, run)
        self.assertEqual(code, 0, err)
        out = os.path.join(tmp, "found.yaml")
        p = subprocess.run([sys.executable, "-m", "analysis.from_scan", os.path.join(run, "scan_initial.gsf"), "--out", out],
                           capture_output=True, text=True, timeout=120)
        self.assertEqual(p.returncode, 0, p.stderr)
        found = yaml.safe_load(open(out))["objects"]["particles"]
        self.assertEqual(len(found), len(scene["objects"]["particles"]), found)
        for t in scene["objects"]["particles"]:
            f = min(found, key=lambda f: (f["x_nm"] - t["x_nm"]) ** 2 + (f["y_nm"] - t["y_nm"]) ** 2)
            for k in ("x_nm", "y_nm", "radius_nm"):
                self.assertAlmostEqual(f[k], t[k], delta=2.0, msg=(k, t, f))

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
        # cut inside a record's header past the middle: a cut at len // 2 alone
        # can land on a record's end (it did on one run's log), leaving a whole log
        at = blob.index(b"\xed\xa1\xda\x01", len(blob) // 2) + 20
        with open(os.path.join(cut, "bus.lcmlog"), "wb") as f:
            f.write(blob[:at])
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
