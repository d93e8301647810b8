"""The bus contract is kept in one place and documented (issue 2, style.md):
one message per .lcm file, lower_snake_t, utime first, a comment with the unit
on every field, an explicit count on every variable array; the channel table of
docs/bus.md (section "## Channels") equals lcmtypes/channels.yaml; .ci/run runs ./afm test; the lcm fuzz
target's committed inputs name a channel of the bus and carry its type.

Each program links what it uses and nothing more (issue 33): the shared
libraries it needs (readelf's NEEDED) are within its allowed list."""
import glob
import os
import re
import shutil
import subprocess
import unittest

import yaml

import e2e_support
from analysis import afmlog

LCM_DIR = os.path.join(e2e_support.SRC, "lcmtypes")


class Messages(unittest.TestCase):
    def test_each_file_one_struct_named_like_the_file_with_utime_first(self):
        files = glob.glob(os.path.join(LCM_DIR, "*.lcm"))
        self.assertGreater(len(files), 10)
        for path in files:
            text = open(path).read()
            structs = re.findall(r"^struct\s+(\w+)", text, re.M)
            self.assertEqual(structs, [os.path.basename(path)[:-4]], path)
            self.assertTrue(structs[0].endswith("_t") and structs[0] == structs[0].lower(), path)
            body = text[text.index("{") + 1:text.rindex("}")]
            fields = [l.strip() for l in body.splitlines()
                      if l.strip() and not l.strip().startswith("//") and not l.strip().startswith("const ")]
            first = fields[0]
            if structs[0] not in ("particle_t", "wire_t", "trench_t"):   # nested element types
                self.assertTrue(first.startswith("int64_t utime;"), f"{path}: first field {first!r}")
            for f in fields:
                self.assertIn("//", f, f"{path}: field without a comment: {f!r}")
                m = re.match(r"\w+\s+\w+\[(\w+)\]", f)
                if m and not m.group(1).isdigit():
                    self.assertRegex(body, r"int32_t\s+%s;" % m.group(1), f"{path}: array count {m.group(1)} undeclared")


class FuzzInputs(unittest.TestCase):
    def test_lcm_inputs_name_their_channel_and_carry_its_type(self):
        # fuzz/fuzz_lcm.cpp: the channel's name and a NUL, then the datagram,
        # so that the seeds and the crash inputs reach the decoder they were
        # made for whatever the order of channels.yaml
        rows = yaml.safe_load(open(os.path.join(LCM_DIR, "channels.yaml")))
        types = {r["channel"]: r["type"] for r in rows}
        paths = glob.glob(os.path.join(e2e_support.SRC, "fuzz", "corpus", "lcm", "*")) + \
            glob.glob(os.path.join(e2e_support.SRC, "fuzz", "crashes", "lcm", "*"))
        self.assertGreater(len(paths), len(types))
        seen = set()
        for path in paths:
            data = open(path, "rb").read()
            name, nul, datagram = data.partition(b"\0")
            self.assertTrue(nul, f"{path}: no channel name")
            channel = name.decode()
            self.assertIn(channel, types, path)
            fingerprint = getattr(afmlog.afm, types[channel])._get_packed_fingerprint()
            self.assertEqual(datagram[:8], fingerprint, f"{path}: not a {types[channel]}")
            seen.add(channel)
        self.assertEqual(seen, set(types), "a seed for every channel")


class ChannelTable(unittest.TestCase):
    def test_bus_md_table_equals_channels_yaml(self):
        rows = yaml.safe_load(open(os.path.join(LCM_DIR, "channels.yaml")))
        text = open(os.path.join(e2e_support.SRC, "docs", "bus.md")).read()
        section = text.split("\n## Channels\n", 1)[1].split("\n## ", 1)[0]
        table = {}
        for line in section.splitlines():
            m = re.match(r"\|\s*`([A-Z_]+)`\s*\|\s*`(\w+)`\s*\|\s*([^|]+?)\s*\|\s*([^|]+?)\s*\|\s*([^|]+?)\s*\|", line)
            if m:
                table[m.group(1)] = (m.group(2), m.group(3), m.group(5), m.group(4))
        self.assertEqual(set(table), {r["channel"] for r in rows})
        for r in rows:
            self.assertEqual(table[r["channel"]][0], r["type"], r["channel"])
            self.assertEqual(table[r["channel"]][1], r["publisher"], r["channel"])
            self.assertEqual(table[r["channel"]][2], r["rate"], r["channel"])
            self.assertEqual(table[r["channel"]][3], r["readers"], r["channel"])

    def test_ci_runs_the_readme_test_command(self):
        ci = open(os.path.join(e2e_support.SRC, ".ci", "run")).read()
        self.assertIn("./afm test", ci)
        readme = open(os.path.join(e2e_support.SRC, "README.md")).read()
        self.assertIn("./afm demo", readme)
        self.assertIn("./afm test", readme)


class RunJsonKeys(unittest.TestCase):
    """run.json's keys are documented in one place (docs/design.md, the
    table under "What a run writes"): a run's keys are all there, and every
    key there is one a run writes (those written only on failure said so in
    their row); it carries its schema version and the build's provenance."""

    def documented(self):
        text = open(os.path.join(e2e_support.SRC, "docs", "design.md")).read()
        table = text[text.index("| key | meaning |"):]
        table = table[:table.index("\n\n")]
        keys, on_failure = set(), set()
        for line in table.splitlines()[2:]:
            first = line.split("|")[1]
            names = re.findall(r"`([a-z_]+)`", first)
            keys |= set(names)
            if "only when something failed" in line:
                on_failure |= set(names)
        return keys, on_failure

    def test_a_runs_keys_are_the_documented_ones(self):
        out = e2e_support.tmpdir("runjson")
        self.addCleanup(e2e_support.cleanup, out)
        code, _, err, rj = e2e_support.run(e2e_support.scene("short.yaml"), out)
        self.assertEqual(code, 0, err)
        keys, on_failure = self.documented()
        self.assertEqual(sorted(set(rj) - keys), [], "keys of run.json docs/design.md does not document")
        self.assertEqual(sorted(keys - set(rj) - on_failure), [], "documented keys an ok run does not write")
        self.assertEqual(rj["schema_version"], 3)
        # the launcher removed its lock as it ended: a finished run's folder keeps none
        self.assertFalse(os.path.exists(os.path.join(out, ".afm-run.lock")), sorted(os.listdir(out)))
        prov = rj["provenance"]
        self.assertEqual(sorted(prov), ["build_type", "commit", "compilers", "dirty", "libraries"])
        # A checkout: the build's commit is the checkout's (built by this ./afm
        # test). A tree got as an archive (no git, or no .git) has no commit
        # to compare with: that one assertion is left out.
        if shutil.which("git") and os.path.exists(os.path.join(e2e_support.SRC, ".git")):
            git = subprocess.run(["git", "-C", e2e_support.SRC, "rev-parse", "HEAD"], capture_output=True, text=True)
            self.assertEqual(git.returncode, 0, git.stderr)
            self.assertEqual(prov["commit"], git.stdout.strip())
            self.assertIn(prov["dirty"], (True, False))
        self.assertTrue(prov["build_type"])
        self.assertRegex(prov["compilers"]["cxx"], r"\d+\.\d+")
        for lib in ("opencv", "eigen", "lcm", "yaml_cpp", "nlohmann_json"):
            self.assertRegex(prov["libraries"][lib], r"^\d+\.\d+", lib)


# The shared libraries each program may need, by name without the version.
_BASE = {"libstdc++", "libm", "libgcc_s", "libc"}
_BUS = _BASE | {"libyaml-cpp", "libglib-2.0"}   # the scene (yaml-cpp) and LCM (GLib)
ALLOWED = {
    "sim_afm/sim_afm": _BUS,
    "host/fw_node": _BUS,
    "host/afm_launch": _BUS,                 # no OpenCV: it is on the path of every run
    "host/afm_replay": _BUS,
    # PNG files read through libpng (host/image/png_read.hpp); no ISA-L, no zlib
    "host/operator": _BUS | {"libopencv_core", "libopencv_imgproc", "libpng16"},
    "host/renderer": _BUS | {"libopencv_core", "libopencv_imgproc", "libpng16",
                                    "libopencv_freetype",   # the frames' and figures' text (host/renderer/frame_font)
                                    "libjpeg",              # the page's frames (host/renderer/jpeg_file.hpp)
                                    "libisal", "libz"},
    # OpenCV's video writer, loaded by the renderer only for its video (host/renderer/cv_video.hpp)
    "host/afm_cv_video.so": _BASE | {"libopencv_core", "libopencv_videoio"},
    "host/afm_netfault": _BASE | {"libnetfilter_queue"},
    "host/afm_media": _BASE | {"libopencv_core", "libopencv_videoio"},
    "host/calc/afm_calc": {"libm", "libc"},
}


def needed(path):
    out = subprocess.run(["readelf", "-d", path], capture_output=True, text=True, check=True).stdout
    return {re.sub(r"\.so(\.[0-9.]+)?$", "", m) for m in re.findall(r"\(NEEDED\)\s+Shared library: \[([^\]]+)\]", out)}


class LinkedLibraries(unittest.TestCase):
    def test_each_program_needs_only_its_allowed_libraries(self):
        for rel, allowed in ALLOWED.items():
            got = needed(os.path.join(e2e_support.BUILD, rel))
            self.assertTrue(got, f"{rel}: readelf found no NEEDED entry")
            self.assertEqual(sorted(got - allowed), [], f"{rel} needs libraries outside its list")

    def test_the_operator_and_renderer_load_no_imgcodecs_or_videoio(self):
        # imgcodecs and videoio bring 139 and 243 shared libraries (GDAL,
        # GDCM, OpenEXR, libavcodec): 0.2-0.3 s of CPU at each start, every run
        for prog in (e2e_support.paths.OPERATOR, e2e_support.paths.RENDERER):
            out = subprocess.run(["ldd", prog], capture_output=True, text=True, check=True).stdout
            loaded = re.findall(r"^\s*(\S+\.so\S*)", out, re.M)
            self.assertEqual([x for x in loaded if "imgcodecs" in x or "videoio" in x], [], prog)
            self.assertLess(len(loaded), 60, f"{prog}: {len(loaded)} shared libraries")

    def test_the_operator_has_no_png_encoder(self):
        got = needed(e2e_support.paths.OPERATOR)
        self.assertNotIn("libisal", got)
        self.assertNotIn("libz", got)


if __name__ == "__main__":
    e2e_support.main()
