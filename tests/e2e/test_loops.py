"""./afm calib tilted --loops (analysis/loops.py): friction loops from a
researcher's own CSV files to mu and k_theta K_l / h with their
uncertainty, through the firmware's own solver. Loops drawn from eq. 16-17
with the paper's constants and a known noise: the slopes and the
calibration come back within their stated errors; bad files are named by
file, line and column. The same loops as Gwyddion files (.gwy, written here
with gwyfile): channels found by their titles or named by the user, the
turnarounds left out, S_n from a channel or per file; a damaged or
ambiguous file is named with its channel and value."""
import json
import os
import re
import subprocess
import sys
import unittest

import numpy as np

import e2e_support

AFM = os.path.join(os.environ["AFM_SOURCE"], "afm")
CALC = e2e_support.paths.CALC
PAPER = dict(phi=9.0, kn=0.12, Kn=89.0)
RU, RD = 0.07, 0.02          # the paper's slopes: mu 0.0865, 37.9 nN/V


def loops_cli(*args):
    env = dict(os.environ, AFM_CALC=CALC)
    return subprocess.run([sys.executable, "-m", "analysis.loops", *map(str, args)], capture_output=True, text=True,
                          env=env, timeout=120)


def write_loops(folder, loads_v, noise_v, seed=3):
    """One CSV per set point: 200 samples each way, S_l = r S_n + offset + noise."""
    rng = np.random.default_rng(seed)
    paths = []
    for k, sn in enumerate(loads_v):
        p = os.path.join(folder, f"loop_{k}.csv")
        with open(p, "w") as f:
            f.write("y_nm,s_n_V,s_l_V,direction\n")
            for d, r, b in (("up", RU, 0.011), ("down", RD, -0.004)):
                for i in range(200):
                    n = sn + rng.normal(0, noise_v)
                    f.write(f"{i},{n:.6f},{r * n + b + rng.normal(0, noise_v):.6f},{d}\n")
        paths.append(p)
    return paths


def loop_images(rng, sn, noise_v, up_pass, rows=32, cols=64):
    """S_n and the lateral trace and retrace of one loop, volts, rows x cols:
    S_l = r S_n + offset + noise (the pass up_pass climbs the facet, slope
    RU), the turnarounds (the outer 5 % of each line) 0.5 V off."""
    n_img = sn + rng.normal(0, noise_v, (rows, cols))
    out = []
    for climbs in (up_pass == "trace", up_pass == "retrace"):
        r, b = (RU, 0.011) if climbs else (RD, -0.004)
        sl = r * n_img + b + rng.normal(0, noise_v, (rows, cols))
        sl[:, :3] += 0.5
        sl[:, -3:] += 0.5
        out.append(sl)
    return n_img, out[0], out[1]


def nanoscope_bytes(channels, rows, cols, lsb_V=1e-4):
    """A Nanoscope (v5, binary) file of channels [(title, Trace|Retrace,
    values V)], 16 bits a sample, as Gwyddion's importer reads it: the
    header's sections (file, scan, scanner, one image list per channel)
    then the data; the titles carry no pass, the Line direction does (as in
    Bruker's own files)."""
    head_B, data_B = 8192, rows * cols * 2
    lines = ["\\*File list", "\\Version: 0x05120005", f"\\Data length: {head_B}", "\\*Ciao scan list",
             f"\\Samps/line: {cols}", f"\\Lines: {rows}", "\\Scan Size: 2000 1000 nm", "\\*Scanner list",
             "\\@Sens. Volts: V 1 "]
    for i, (title, direction, _) in enumerate(channels):
        lines += ["\\*Ciao image list", f"\\Data offset: {head_B + i * data_B}", f"\\Data length: {data_B}",
                  "\\Bytes/pixel: 2", f"\\Samps/line: {cols}", f"\\Number of lines: {rows}",
                  "\\Scan Size: 2000 1000 nm", f"\\Line direction: {direction}", f'\\@2:Image Data: S [{title}] "{title}"',
                  f"\\@2:Z scale: V [Sens. Volts] ({lsb_V} V/LSB) {lsb_V * 65536:.6f} V"]
    head = ("\r\n".join(lines + ["\\*File list end"]) + "\r\n").encode()
    body = b"".join(np.round(v / lsb_V).astype("<i2").tobytes() for _, _, v in channels)
    return head + b"\x1a" * (head_B - len(head)) + body


def write_nanoscope_loops(folder, loads_v, noise_v, up_pass="trace", seed=7):
    """One Nanoscope file per set point (loop_K.000), the loops of loop_images."""
    rng = np.random.default_rng(seed)
    paths = []
    for k, sn in enumerate(loads_v):
        n_img, trace, retrace = loop_images(rng, sn, noise_v, up_pass)
        chans = [("Height", "Trace", np.zeros_like(n_img)), ("Friction", "Trace", trace), ("Friction", "Retrace", retrace),
                 ("Deflection", "Trace", n_img), ("Deflection", "Retrace", n_img)]
        path = os.path.join(folder, f"loop_{k}.000")
        with open(path, "wb") as f:
            f.write(nanoscope_bytes(chans, *n_img.shape))
        paths.append(path)
    return paths


def write_gwy_loops(folder, loads_v, noise_v, up_pass="trace", normal="Vertical deflection", lateral_unit="V",
                    extra=(), seed=5, lateral="Friction"):
    """One .gwy per set point: a 32 x 64 image per channel, the lateral trace
    and retrace S_l = r S_n + offset + noise (the pass up_pass climbs the
    facet, slope RU), the turnarounds (the outer 5 % of each line) 0.5 V off;
    a height channel, the lateral ones titled lateral (trace) and (retrace),
    the normal channel titled normal (None: none) and the extra (title,
    value V) channels."""
    import gwyfile.objects as g
    rng = np.random.default_rng(seed)
    paths = []
    for k, sn in enumerate(loads_v):
        c = g.GwyContainer()

        def add(n, title, data, unit="V"):
            c[f"/{n}/data/title"] = title
            c[f"/{n}/data"] = g.GwyDataField(data, xreal=2e-6, yreal=1e-6, si_unit_xy="m", si_unit_z=unit)
        n_img, trace, retrace = loop_images(rng, sn, noise_v, up_pass)
        rows, cols = n_img.shape
        add(0, "Height", np.tile(np.linspace(0, 3e-7, cols), (rows, 1)), unit="m")
        add(1, f"{lateral} (trace)", trace, unit=lateral_unit)
        add(2, f"{lateral} (retrace)", retrace, unit=lateral_unit)
        if normal:
            add(3, normal, n_img)
        for i, (title, value) in enumerate(extra):
            add(4 + i, title, np.full((rows, cols), value))
        path = os.path.join(folder, f"loop_{k}.gwy")
        c.tofile(path)
        paths.append(path)
    return paths


def flags():
    return ["--angle-deg", PAPER["phi"], "--spring-N-per-m", PAPER["kn"], "--deflection-nm-per-V", PAPER["Kn"]]


class Loops(unittest.TestCase):
    def setUp(self):
        self.dir = e2e_support.tmpdir("loops")
        self.addCleanup(e2e_support.cleanup, self.dir)

    def test_the_paper_calibration_comes_back_within_its_stated_error(self):
        files = write_loops(self.dir, [0.5, 1.0, 1.5, 2.0, 2.5], noise_v=0.002)
        inc = os.path.join(self.dir, "cal.yaml")
        p = loops_cli("--loops", *files, *flags(), "--json", "--write", inc)
        self.assertEqual(p.returncode, 0, p.stderr)
        r = json.loads(p.stdout)
        exact = json.loads(subprocess.run([CALC, "calib", "tilted", "--up", str(RU), "--down", str(RD), "--angle-deg", "9",
                                           "--spring-N-per-m", "0.12", "--deflection-nm-per-V", "89", "--json"],
                                          capture_output=True, text=True, check=True).stdout)
        print(f"loops: r_u {r['r_u']:.5f} +- {r['r_u_se']:.5f}, mu {r['mu']:.5f} +- {r['mu_se']:.5f} (exact {exact['mu']:.5f}), "
              f"lateral {r['lateral_nN_per_V']:.3f} +- {r['lateral_nN_per_V_se']:.3f} (exact {exact['lateral_nN_per_V']:.3f})")
        for key, se in (("r_u", "r_u_se"), ("r_d", "r_d_se")):
            self.assertGreater(r[se], 0)
            self.assertLess(abs(r[key] - (RU if key == "r_u" else RD)), 4 * r[se], key)
        for key in ("mu", "lateral_nN_per_V"):
            self.assertGreater(r[key + "_se"], 0, key)
            self.assertLess(abs(r[key] - exact[key]), 4 * r[key + "_se"], key)
        self.assertTrue(os.path.exists(inc))
        # more noise, larger stated errors
        noisy = write_loops(self.dir, [0.5, 1.0, 1.5, 2.0, 2.5], noise_v=0.02, seed=4)
        r2 = json.loads(loops_cli("--loops", *noisy, *flags(), "--json").stdout)
        self.assertGreater(r2["mu_se"], 3 * r["mu_se"])

    def test_one_csv_with_every_set_point_is_the_same_as_one_file_each(self):
        # a lab's one CSV: the per-file loops' rows, each with a set_point column
        files = write_loops(self.dir, [0.5, 1.0, 1.5, 2.0], noise_v=0.002)
        whole = os.path.join(self.dir, "all_set_points.csv")
        with open(whole, "w") as out:
            out.write("set_point,y_nm,s_n_V,s_l_V,direction\n")
            for k, path in enumerate(files):
                with open(path) as f:
                    next(f)
                    out.writelines(f"{k * 0.5 + 0.5}nN,{line}" for line in f)
        each = json.loads(loops_cli("--loops", *files, *flags(), "--json").stdout)
        p = loops_cli("--loops", whole, *flags(), "--json")
        self.assertEqual(p.returncode, 0, p.stderr)
        one = json.loads(p.stdout)
        self.assertEqual(one["loops"], 4)
        for key in ("r_u", "r_d", "mu", "lateral_nN_per_V", "mu_se"):
            self.assertAlmostEqual(one[key], each[key], places=9, msg=key)
        # a set_point column with an empty cell, and too few set points, are named
        with open(whole) as f:
            lines = f.readlines()
        bad = os.path.join(self.dir, "blank_set_point.csv")
        with open(bad, "w") as f:
            f.writelines(lines[:3] + ["," + lines[3].split(",", 1)[1]])
        p = loops_cli("--loops", bad, *flags())
        self.assertEqual(p.returncode, 2)
        self.assertIn(f"{bad}: line 4: set_point is empty", p.stderr)
        two = os.path.join(self.dir, "two_set_points.csv")
        with open(two, "w") as f:
            f.writelines([ln for ln in lines if not ln.startswith(("1.5nN", "2.0nN"))])
        p = loops_cli("--loops", two, *flags())
        self.assertEqual(p.returncode, 2)
        self.assertIn("--loops: 2 set point(s) in 1 file(s); at least 3 set points", p.stderr)

    def test_calib_tilted_help_names_loops(self):
        p = subprocess.run([AFM, "calib", "tilted", "--help"], capture_output=True, text=True, timeout=60)
        self.assertEqual(p.returncode, 0, p.stderr)
        self.assertIn("--loops FILE", p.stdout)
        self.assertIn("set_point", p.stdout)

    def test_bad_files_are_named(self):
        good = write_loops(self.dir, [0.5, 1.0, 1.5], noise_v=0.002)
        cases = {
            "no_direction.csv": ("s_n_V,s_l_V\n1,0.1\n", "line 1: missing column(s) direction"),
            "word.csv": ("s_n_V,s_l_V,direction\n1,0.1,up\nabc,0.1,down\n", "line 3: s_n_V and s_l_V must be numbers"),
            "sideways.csv": ("s_n_V,s_l_V,direction\n1,0.1,left\n", "line 2: direction must be up or down"),
            "nan.csv": ("s_n_V,s_l_V,direction\n1,nan,up\n", "line 2: not finite"),
            "one_way.csv": ("s_n_V,s_l_V,direction\n1,0.1,up\n1.1,0.1,up\n", "going down: a loop needs both passes"),
        }
        for name, (text, want) in cases.items():
            path = os.path.join(self.dir, name)
            with open(path, "w") as f:
                f.write(text)
            p = loops_cli("--loops", good[0], good[1], path, *flags())
            self.assertEqual(p.returncode, 2, name)
            self.assertIn(path, p.stderr, name)
            self.assertIn(want, p.stderr, name)
        p = loops_cli("--loops", good[0], good[1], *flags())
        self.assertEqual(p.returncode, 2)
        self.assertIn("at least 3 set points", p.stderr)
        p = loops_cli("--loops", good[0], good[0], good[0], *flags())
        self.assertEqual(p.returncode, 2)
        self.assertIn("the same S_n", p.stderr)
        p = loops_cli("--loops", self.dir, good[1], good[2], *flags())
        self.assertEqual(p.returncode, 2)
        self.assertIn("not a file", p.stderr)
        p = loops_cli("--loops", *good, *flags(), "--s-n-V", "0.5", "1.0", "1.5")
        self.assertEqual(p.returncode, 2)
        self.assertIn(f"{good[0]}: --s-n-V is for image files; a CSV loop has its own s_n_V column", p.stderr)

    def test_the_afm_entry_point_routes_loops(self):
        files = write_loops(self.dir, [0.5, 1.0, 1.5], noise_v=0.002)
        p = subprocess.run([AFM, "calib", "tilted", "--loops", *files, *map(str, flags())], capture_output=True, text=True,
                           timeout=e2e_support.limit(300))
        self.assertEqual(p.returncode, 0, p.stderr)
        self.assertIn("mu = 0.08", p.stdout)
        self.assertIn("+-", p.stdout)


class HostileLoops(unittest.TestCase):
    """Files that raised a traceback or were refused for nothing (issue 46):
    a binary file and a 50 MB field are one line and exit 2; a UTF-8
    byte-order mark (Excel's CSV) is read; every C0 and C1 control byte in a
    value or a file name comes out escaped (analysis/text.py)."""

    def setUp(self):
        self.dir = e2e_support.tmpdir("loops-hostile")
        self.addCleanup(e2e_support.cleanup, self.dir)
        self.good = write_loops(self.dir, [0.5, 1.0, 1.5], noise_v=0.002)

    def write(self, name, data):
        path = os.path.join(os.fsencode(self.dir), os.fsencode(name))
        with open(path, "wb") as f:
            f.write(data)
        return os.fsdecode(path)

    def test_a_binary_file_and_a_huge_field_are_one_line(self):
        rng = np.random.default_rng(46)
        for name, data, want in (
                ("binary.csv", rng.integers(0, 256, 3000, dtype=np.uint8).tobytes(), "not UTF-8 text"),
                ("huge.csv", b"s_n_V,s_l_V,direction\n1,0.1,up\n1," + b"9" * (50 << 20) + b",up\n", "line 3: not a CSV loop file"),
                ("nul.csv", b"s_n_V,s_l_V,direction\n1,0.1,up\n\0,\0,up\n", "line 3")):
            path = self.write(name, data)
            p = loops_cli("--loops", path, *self.good[1:], self.good[0], *flags())
            self.assertEqual(p.returncode, 2, (name, p.stderr[-500:]))
            self.assertEqual(len(p.stderr.strip().splitlines()), 1, (name, p.stderr[-500:]))
            self.assertIn(want, p.stderr, name)
            self.assertNotIn("Traceback", p.stderr, name)

    def test_a_byte_order_mark_is_read(self):
        boms = []
        for k, path in enumerate(self.good):
            with open(path, "rb") as f:
                boms.append(self.write(f"bom_{k}.csv", b"\xef\xbb\xbf" + f.read()))
        plain = json.loads(loops_cli("--loops", *self.good, *flags(), "--json").stdout)
        p = loops_cli("--loops", *boms, *flags(), "--json")
        self.assertEqual(p.returncode, 0, p.stderr)
        self.assertEqual(json.loads(p.stdout)["mu"], plain["mu"])

    def test_every_control_byte_comes_out_escaped(self):
        import contextlib
        import io
        from analysis import loops
        controls = [bytes([b]) for b in range(1, 0x20)] + [b"\x7f"] + [bytes([0xC2, c]) for c in range(0x80, 0xA0)]
        for raw in controls:
            esc = "".join("\\x%02X" % c for c in raw)
            for path, want in ((self.write("v.csv", b's_n_V,s_l_V,direction\n1,0.1,"u' + raw + b'p"\n'), f"got 'u{esc}p'"),
                               (self.write(b"name" + raw + b".csv", b"s_n_V,s_l_V\n"), f"name{esc}.csv: line 1")):
                err = io.StringIO()
                with contextlib.redirect_stderr(err):
                    code = loops.main(["--loops", path, *map(str, self.good), *map(str, flags()), "--calc", CALC])
                self.assertEqual(code, 2, err.getvalue())
                self.assertIn(want, err.getvalue())
                self.assertIsNone(re.search("[\x00-\x09\x0b-\x1f\x7f-\x9f]", err.getvalue()), err.getvalue())


class GwyLoops(unittest.TestCase):
    LOADS = [0.5, 1.0, 1.5, 2.0, 2.5]

    def setUp(self):
        self.dir = e2e_support.tmpdir("loops_gwy")
        self.addCleanup(e2e_support.cleanup, self.dir)
        self.exact = json.loads(subprocess.run([CALC, "calib", "tilted", "--up", str(RU), "--down", str(RD), "--angle-deg", "9",
                                                "--spring-N-per-m", "0.12", "--deflection-nm-per-V", "89", "--json"],
                                               capture_output=True, text=True, check=True).stdout)

    def assert_calibration(self, r, label):
        print(f"loops gwy {label}: r_u {r['r_u']:.5f} +- {r['r_u_se']:.5f}, r_d {r['r_d']:.5f} +- {r['r_d_se']:.5f}, "
              f"mu {r['mu']:.5f} +- {r['mu_se']:.5f} (exact {self.exact['mu']:.5f}), lateral {r['lateral_nN_per_V']:.3f} "
              f"+- {r['lateral_nN_per_V_se']:.3f} (exact {self.exact['lateral_nN_per_V']:.3f})")
        for key, want in (("r_u", RU), ("r_d", RD), ("mu", self.exact["mu"]),
                          ("lateral_nN_per_V", self.exact["lateral_nN_per_V"])):
            self.assertGreater(r[key + "_se"], 0, (label, key))
            self.assertLess(abs(r[key] - want), 4 * r[key + "_se"], (label, key))

    def run_json(self, files, *extra):
        p = loops_cli("--loops", *files, *flags(), "--json", *extra)
        self.assertEqual(p.returncode, 0, p.stderr)
        return json.loads(p.stdout)

    def test_gwyddion_loops_give_the_known_calibration(self):
        # "Lateral deflection" is S_l, not S_n, though it says deflection
        files = write_gwy_loops(self.dir, self.LOADS, noise_v=0.002, lateral="Lateral deflection")
        self.assert_calibration(self.run_json(files, "--up-pass", "trace"), "found by titles")
        # the turnarounds matter: kept in, they pull the fit off the known slopes
        r = self.run_json(files, "--up-pass", "trace", "--edge-fraction", "0")
        self.assertGreater(abs(r["r_u"] - RU) + abs(r["intercept_up_V"] - 0.011), 0.02)
        # the retrace climbing, channels named by number and by title
        sub = os.path.join(self.dir, "retrace")
        os.makedirs(sub)
        files = write_gwy_loops(sub, self.LOADS, noise_v=0.002, up_pass="retrace", seed=6)
        self.assert_calibration(self.run_json(files, "--up-pass", "retrace", "--lateral-trace", "1",
                                              "--lateral-retrace", "friction (RETRACE)", "--normal", "3"), "named")

    def test_nanoscope_loops_through_gwyddion_give_the_known_calibration(self):
        # the pass from each channel's Line direction (Gwyddion keeps it as metadata), not its title
        files = write_nanoscope_loops(self.dir, self.LOADS, noise_v=0.002, up_pass="retrace")
        self.assert_calibration(self.run_json(files, "--up-pass", "retrace"), "Nanoscope")
        # Gwyddion reads no such format: the file is named with what Gwyddion said
        odd = os.path.join(self.dir, "loop.txt")
        with open(odd, "w") as f:
            f.write("s_n_V,s_l_V,direction\n1,0.1,up\n")
        p = loops_cli("--loops", odd, *files[:2], *flags(), "--up-pass", "retrace")
        self.assertEqual(p.returncode, 2)
        self.assertIn(f"{odd}: not .csv nor .gwy, and Gwyddion does not read it (gwyddion:", p.stderr)
        # two friction channels of one pass: named with both titles and passes listed
        p = loops_cli("--loops", files[0], *files[1:3], *flags(), "--up-pass", "retrace", "--normal", "Deflection")
        self.assertEqual(p.returncode, 2)
        self.assertIn(f"{files[0]}: --normal 'Deflection': 2 channel(s) of that title or number (channels: 0 'Height', "
                      "1 'Friction', 2 'Friction' (retrace), 3 'Deflection', 4 'Deflection' (retrace))", p.stderr)

    def test_set_points_given_per_file_instead_of_a_normal_channel(self):
        files = write_gwy_loops(self.dir, self.LOADS, noise_v=0.0005, normal=None, extra=[("Deflection Error", 0.3)])
        p = loops_cli("--loops", *files, *flags(), "--up-pass", "trace")
        self.assertEqual(p.returncode, 2)
        self.assertIn("no channel titled as deflection/normal/vertical for S_n (an error signal is not S_n)", p.stderr)
        self.assertIn("4 'Deflection Error'", p.stderr)
        self.assert_calibration(self.run_json(files, "--up-pass", "trace", "--s-n-V", *map(str, self.LOADS)), "--s-n-V")
        p = loops_cli("--loops", *files, *flags(), "--up-pass", "trace", "--s-n-V", "0.5", "1.0")
        self.assertEqual(p.returncode, 2)
        self.assertIn("--s-n-V: 2 value(s) for 5 loop file(s)", p.stderr)

    def test_bad_gwyddion_files_are_named_with_channel_and_value(self):
        good = write_gwy_loops(self.dir, [0.5, 1.0], noise_v=0.002)
        odd = os.path.join(self.dir, "odd")
        os.makedirs(odd)
        cases = []

        def case(name, want, *opts, write=None, **kw):
            folder = os.path.join(odd, name)
            os.makedirs(folder)
            path = write(folder) if write else write_gwy_loops(folder, [1.5], noise_v=0.002, **kw)[0]
            cases.append((name, path, opts, want))

        def text_file(folder):
            path = os.path.join(folder, "scan.gwy")
            with open(path, "w") as f:
                f.write("this is a CSV\n")
            return path

        def truncated(folder):
            path = write_gwy_loops(folder, [1.5], noise_v=0.002)[0]
            with open(path, "rb") as f:
                data = f.read()
            with open(path, "wb") as f:
                f.write(data[:len(data) // 2])
            return path
        case("text", "not a Gwyddion file: it starts with b'this'", write=text_file)
        case("truncated", "cannot be read as a Gwyddion file", write=truncated)
        case("no_up_pass", "which pass climbs the facet? name it with --up-pass")
        case("metres", "channel 1 'Friction (trace)': unit 'm', the loop needs volts", lateral_unit="m")
        case("two_traces", "2 channel(s) titled as lateral/friction/lfm/torsion (trace); name it with --lateral-trace",
             extra=[("Lateral force", 0.1)])
        case("named_wrong", "--lateral-trace 'Torsion': no channel(s) of that title or number", "--lateral-trace", "Torsion")
        for name, path, opts, want in cases:
            up = [] if name == "no_up_pass" else ["--up-pass", "trace"]
            p = loops_cli("--loops", path, *good, *flags(), *up, *opts)   # the odd file first: it is the one named
            self.assertEqual(p.returncode, 2, (name, p.stderr))
            self.assertIn(path, p.stderr, name)
            self.assertIn(want, p.stderr, name)
        self.assertIn("(channels: 0 'Height', 1 'Friction (trace)', 2 'Friction (retrace)', 3 'Vertical deflection', "
                      "4 'Lateral force')", loops_cli("--loops", *good, cases[4][1], *flags(), "--up-pass", "trace").stderr)


if __name__ == "__main__":
    unittest.main(verbosity=2)
