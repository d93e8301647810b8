"""Bad input (issue 2): a scene with an unknown key, a missing required value,
a negative radius, a NaN, or a file that is not there makes the launcher exit
non-zero before starting anything, with one line naming the file, the key and
the value. A process that dies mid-run: the launcher stops the others, says
which one died and its exit code, keeps the log and run.json, exits non-zero.
And the bus never opens in a namespace whose multicast would leave the machine."""
import os
import time
import json
import subprocess
import unittest

import e2e_support

GOOD = open(e2e_support.scene("short.yaml")).read()


class BadScenes(unittest.TestCase):
    def check_refused(self, text, key, value_text):
        path = e2e_support.write_scene(text, "bad")
        out = os.path.join(os.path.dirname(path), "out")
        code, stdout, stderr, _ = e2e_support.run(path, out)
        lines = [l for l in stderr.splitlines() if l.strip()]
        self.assertNotEqual(code, 0)
        self.assertEqual(len(lines), 1, stderr)
        self.assertIn(path, lines[0])
        self.assertIn(key, lines[0])
        self.assertIn(value_text, lines[0])
        self.assertFalse(os.path.exists(out), "nothing may start for a bad scene")
        e2e_support.cleanup(os.path.dirname(path))
        return lines[0]

    def test_unknown_key_named(self):
        msg = self.check_refused(GOOD.replace("duration_s: 0.6", "duration_s: 0.6\ndurration_s: 0.6"), "durration_s", "unknown key")
        self.assertIn("duration_s", msg)   # the known keys are listed

    def test_missing_required_value_named(self):
        self.check_refused(GOOD.replace("duration_s: 0.6\n", ""), "duration_s", "required value is missing")

    def test_negative_radius_named_with_value(self):
        self.check_refused(GOOD.replace("x_nm: 0, y_nm: -300, radius_nm: 50", "x_nm: 0, y_nm: -300, radius_nm: -5"),
                           "objects.particles[0].radius_nm", "'-5'")

    def test_nan_named_with_value(self):
        self.check_refused(GOOD.replace("mu: 0.0865", "mu: .nan"), "sample.tip_substrate.mu", "'.nan'")

    def test_a_key_nothing_would_read_is_refused_by_name(self):
        # the tip slides on the substrate by mu and adhesion alone (issue 47: keys that work)
        for key in ("shear_strength_MPa", "contact_area_nm2"):
            msg = self.check_refused(GOOD.replace("mu: 0.0865", f"mu: 0.0865, {key}: 5"), f"sample.tip_substrate.{key}", "not used")
            self.assertIn("sample.particle_substrate", msg)

    def test_a_path_that_starts_inside_a_particle_is_refused(self):
        # particle 1 at (0, -300), radius 50; the tip's apex radius 10: 55 nm away is inside, 60 touches
        msg = self.check_refused(GOOD.replace("- [0, -700]", "- [0, -355]"), "operator.path_nm[0]", "starts inside objects.particles[0]")
        self.assertIn("55.0 nm", msg)
        path = e2e_support.write_scene(GOOD.replace("- [0, -700]", "- [0, -360]"), "touching")
        p = subprocess.run([e2e_support.LAUNCH, "--check", "--scene", path], capture_output=True, text=True, timeout=60)
        self.assertEqual(p.returncode, 0, p.stderr)   # touching is allowed
        e2e_support.cleanup(os.path.dirname(path))

    def test_negative_roughness_named_with_value(self):
        self.check_refused(GOOD.replace("field_nm: 2000", "field_nm: 2000\n  roughness_rms_nm: -1"), "sample.roughness_rms_nm", "'-1'")

    def test_infinity_named_with_value(self):
        self.check_refused(GOOD.replace("duration_s: 0.6", "duration_s: .inf"), "duration_s", "'.inf'")

    def test_wrong_type_named_with_value(self):
        self.check_refused(GOOD.replace("load_nN: 5", "load_nN: five"), "operator.load_nN", "'five'")

    def test_unknown_effect_named(self):
        self.check_refused(GOOD.replace("effects: [bending_offset,", "effects: [bending_ofset,"), "effects[0]", "'bending_ofset'")

    def test_waypoint_out_of_reach_named(self):
        self.check_refused(GOOD.replace("- [300, -90]", "- [3000, -90]"), "operator.path_nm[2]", "[3000, -90]")

    def test_block_rate_not_dividing_sample_rate_named(self):
        self.check_refused(GOOD.replace("block_hz: 1000", "block_hz: 3000"), "block_hz", "'3000'")

    def test_lever_the_firmware_refuses_named_with_values(self):
        # The card's own init (fw_card_init) decides, on what the card is
        # given (its firmware.* section, never the probe's truth); the
        # launcher names the rule in the firmware's words with the scene
        # keys that feed it.
        # C_n = 3 h K_n / (2 l) = 11250 nm/V: beyond the bending
        # compensation's 4194.304 nm/V (FW_RULE_DISP_RANGE)
        lever = "firmware: {tip_height_um: 50, deflection_nm_per_V: 9000, lever_length_um: 60}\nobjects:"
        msg = self.check_refused(GOOD.replace("objects:", lever, 1), "firmware.tip_height_um", "4194304 pm/V")
        self.assertIn("tip_height_um 50", msg)
        self.assertIn("lever_length_um 60", msg)
        self.assertIn("deflection_nm_per_V 9000", msg)
        self.assertIn("estimate C_n = C_l = 3 h K_n / (2 l) = 11250 nm/V", msg)
        # h = l: 2h/l = 2 is no lever for eq. 1c
        lever = "firmware: {tip_height_um: 50, deflection_nm_per_V: 10, lever_length_um: 50}\nobjects:"
        msg = self.check_refused(GOOD.replace("objects:", lever, 1), "firmware.tip_height_um", "2h/l < 2")
        self.assertIn("fw_card_init: FW_ERR_DOMAIN", msg)
        # mu 2h/l = 0.9 * 1.2 > 1/2: the friction fallback's denominator
        lever = "firmware: {tip_height_um: 60, lever_length_um: 100, mu: 0.9}\nobjects:"
        msg = self.check_refused(GOOD.replace("objects:", lever, 1), "firmware.mu", "mu 2h/l <= 1/2")
        self.assertIn("firmware.mu 0.9", msg)
        self.assertIn("firmware.tip_height_um 60", msg)
        # a range only the card knows: 20 ADC bits
        msg = self.check_refused(GOOD.replace("objects:", "firmware: {adc_bits: 20}\nobjects:", 1), "firmware.adc_bits",
                                 "8 to 16 bits")
        self.assertIn("firmware.adc_bits 20", msg)
        msg = self.check_refused(GOOD.replace("objects:", "firmware: {word_bits: 24}\nobjects:", 1), "firmware.word_bits",
                                 "16 or 32 bits")
        self.check_refused(GOOD.replace("objects:", "firmware: {drift_max_step_nm: -5}\nobjects:", 1),
                           "firmware.drift_max_step_nm", "must be > 0, got '-5'")
        self.check_refused(GOOD.replace("objects:", "firmware: {drift_filter: sideways}\nobjects:", 1),
                           "firmware.drift_filter", "must be one of kalman, step, got 'sideways'")
        self.check_refused(GOOD.replace("objects:", "firmware: {drift_filter: kalman, drift_scan_sigma_nm: -1}\nobjects:", 1),
                           "firmware.drift_scan_sigma_nm", "must be >= 0, got '-1'")

    def test_plan_cuts_named(self):
        with open(e2e_support.scene("paper/trench.yaml")) as f:
            trench = f.read()
        self.check_refused(trench.replace("load_nN: 55}", "load_nN: 15}"), "operator.plan.cuts[0].load_nN",
                           "must exceed sample.lithography.threshold_nN")
        self.check_refused(trench.replace("from_nm: [-1400, 200]", "from_nm: [-2400, 200]"), "operator.plan.cuts[0].from_nm",
                           "outside the field")
        self.check_refused(trench.replace(", lithography]", "]"), "operator.plan.cuts", "needs the lithography effect")
        self.check_refused(trench.replace("load_nN: 55}", "load_nN: 55, depth_nm: 3}"), "operator.plan.cuts[0].depth_nm",
                           "unknown key")

    def test_a_local_scans_fix_is_drift_or_place(self):
        self.check_refused(GOOD.replace("{at_s: 0.04, around_id: 1, size_nm: 300}",
                                        "{at_s: 0.04, around_id: 1, size_nm: 300, fix: sideways}"),
                           "operator.local_scans[0].fix", "sideways")

    def test_browser_plan_takes_settings_but_no_cuts(self):
        browser = GOOD.replace("operator:\n", "time_mode: realtime\noperator:\n  mode: browser\n", 1)
        self.check_refused(browser.replace("  mode: browser\n", "  mode: browser\n  plan: {tolerance_nm: 15, cuts: []}\n"),
                           "operator.plan.cuts", "sets only the strokes asked for")
        self.check_refused(browser.replace("  mode: browser\n", "  mode: browser\n  plan: {tolerance_nm: -3}\n"),
                           "operator.plan.tolerance_nm", "'-3'")

    def test_empty_file_refused(self):
        path = e2e_support.write_scene("", "empty")
        code, _, stderr, _ = e2e_support.run(path, os.path.join(os.path.dirname(path), "out"))
        self.assertEqual(code, 2)
        self.assertIn(path, stderr)
        self.assertIn("empty", stderr)

    def test_a_directory_a_fifo_and_an_oversized_file_are_refused_by_type(self):
        tmp = e2e_support.tmpdir("types")
        self.addCleanup(e2e_support.cleanup, tmp)
        fifo = os.path.join(tmp, "scene.fifo")
        os.mkfifo(fifo)
        big = os.path.join(tmp, "big.yaml")
        with open(big, "w") as f:
            f.write("# " + "x" * (5 << 20) + "\n")
        for path, words in ((tmp, "it is a directory"), (fifo, "it is a FIFO"), ("/dev/null", "it is a device"),
                            (big, "larger than a scene may be")):
            code, _, stderr, _ = e2e_support.run(path, os.path.join(tmp, "out"), timeout=30)   # a FIFO used to hang
            lines = [l for l in stderr.splitlines() if l.strip()]
            self.assertEqual(code, 2, stderr)
            self.assertEqual(len(lines), 1, stderr)
            self.assertIn(path, lines[0])
            self.assertIn(words, lines[0])
        # an include that is a directory, named the same way
        inc = e2e_support.write_scene(open(e2e_support.scene("short.yaml")).read() + f"include: {tmp}\n", "inc-dir")
        self.addCleanup(e2e_support.cleanup, os.path.dirname(inc))
        code, _, stderr, _ = e2e_support.run(inc, os.path.join(tmp, "out2"), timeout=30)
        self.assertEqual(code, 2, stderr)
        self.assertIn("it is a directory", stderr)

    def test_a_frame_rate_the_writer_cannot_take_is_named(self):
        text = open(e2e_support.scene("short.yaml")).read().replace("frame_rate_hz: 25", "frame_rate_hz: 1e-300")
        self.check_refused(text, "frame_rate_hz", "1e-300")

    def test_control_characters_are_escaped_and_long_values_cut(self):
        base = open(e2e_support.scene("short.yaml")).read()
        line = self.check_refused(base.replace("duration_s: 0.6", 'duration_s: "0.6\\e[31m\\nX"'), "duration_s",
                                  "\\x1B[31m")   # common/text.hpp's escapes (every control byte: test_hostile_input)
        self.assertNotIn("\x1b", line)
        self.assertIn("\\x0AX", line)
        line = self.check_refused(base.replace("substrate: glass", "substrate: " + "z" * 5000), "sample.substrate",
                                  "(5000 characters)")
        self.assertLess(len(line), 400, line)

    def test_listed_objects_are_capped_as_scattered_ones(self):
        base = open(e2e_support.scene("short.yaml")).read()
        many = "\n".join(f"    - {{id: {i}, x_nm: {(i % 100) * 15 - 750}, y_nm: {(i // 100) * 15 - 750}, radius_nm: 5}}"
                         for i in range(1, 5002))
        text = base.replace("""    - {id: 1, x_nm: 0, y_nm: -300, radius_nm: 50}
    - {id: 2, x_nm: 500, y_nm: 300, radius_nm: 50}""", many)
        self.check_refused(text, "objects.particles", "5001 particles; at most 5000")

    def test_missing_file_named(self):
        path = "/nonexistent/afm/scene.yaml"
        code, _, stderr, _ = e2e_support.run(path, e2e_support.tmpdir("missing"))
        lines = [l for l in stderr.splitlines() if l.strip()]
        self.assertEqual(code, 2)
        self.assertEqual(len(lines), 1, stderr)
        self.assertIn(path, lines[0])
        self.assertIn("cannot open", lines[0])

    def test_yaml_syntax_error_names_line(self):
        path = e2e_support.write_scene(GOOD.replace("seed: 7", "seed: [7"), "syntax")
        code, _, stderr, _ = e2e_support.run(path, os.path.join(os.path.dirname(path), "out"))
        self.assertEqual(code, 2)
        self.assertIn(path, stderr)
        self.assertIn("line", stderr)

    def test_interlock_limits_and_z_speed_named(self):
        self.check_refused(GOOD.replace("objects:", "firmware: {interlock_normal_nN: -5}\nobjects:", 1),
                           "firmware.interlock_normal_nN", "must be > 0, got '-5'")
        msg = self.check_refused(GOOD.replace("objects:", "firmware: {interlock_normal_nN: 106.8}\nobjects:", 1),
                                 "firmware.interlock_normal_nN", "below the normal channel's full scale")
        self.assertIn("firmware.interlock_normal_nN 106.8", msg)
        self.assertIn("k_n K_n 10 V = 106.8 nN", msg)
        msg = self.check_refused(GOOD.replace("objects:", "firmware: {interlock_lateral_nN: 400}\nobjects:", 1),
                                 "firmware.interlock_lateral_nN", "below the lateral channel's full scale")
        self.assertIn("k_theta K_l / h 10 V = 379 nN", msg)
        self.check_refused(GOOD.replace("objects:", "firmware: {interlock: maybe}\nobjects:", 1), "firmware.interlock", "must be true or false")
        self.check_refused(GOOD.replace("objects:", "afm: {z_speed_nm_per_s: -1}\nobjects:", 1), "afm.z_speed_nm_per_s", "must be >= 0, got '-1'")


class ThroughTheAfmScript(unittest.TestCase):
    """The same contract through the README's entry point, ./afm."""

    def test_help_of_each_command_needs_no_build(self):
        # './afm run --help' and './afm check --help' built first, then
        # failed ('--help: cannot open scene file', exit 2)
        for cmd in ("run", "check", "demo", "test", "spy", "bench", "setup", "build", "replay", "calc"):
            for flag in ("--help", "-h"):
                t0 = time.monotonic()
                p = subprocess.run([os.path.join(e2e_support.SRC, "afm"), cmd, flag], capture_output=True, text=True, timeout=60)
                self.assertEqual(p.returncode, 0, (cmd, flag, p.stderr))
                self.assertIn("usage" if cmd in ("replay", "calc") else f"./afm {cmd}", p.stdout, (cmd, p.stdout))
                self.assertNotIn("building", p.stderr, cmd)
                self.assertLess(time.monotonic() - t0, 5.0, cmd)
        for b in ("firmware", "sim", "render", "bus", "sweep"):   # each bench's own text
            p = subprocess.run([os.path.join(e2e_support.SRC, "afm"), "bench", b, "--help"], capture_output=True, text=True,
                               timeout=60)
            self.assertEqual(p.returncode, 0, (b, p.stderr))
            self.assertIn(f"usage: ./afm bench {b}", p.stdout)
            self.assertNotIn("building", p.stderr, b)

    def test_afm_run_refuses_a_bad_scene_naming_file_key_value(self):
        path = e2e_support.write_scene(GOOD.replace("radius_nm: 50", "radius_nm: -5", 1), "afm-bad")
        p = subprocess.run([os.path.join(e2e_support.SRC, "afm"), "run", path, "--out", os.path.join(os.path.dirname(path), "out")],
                           capture_output=True, text=True, timeout=300)
        self.assertNotEqual(p.returncode, 0)
        named = [l for l in p.stderr.splitlines() if path in l]
        self.assertEqual(len(named), 1, p.stderr)
        self.assertIn("objects.particles[0].radius_nm", named[0])
        self.assertIn("'-5'", named[0])
        self.assertFalse(os.path.exists(os.path.join(os.path.dirname(path), "out")))
        e2e_support.cleanup(os.path.dirname(path))

    def test_check_mode_needs_no_output_folder(self):
        p = subprocess.run([e2e_support.LAUNCH, "--check", "--scene", e2e_support.scene("default.yaml")],
                           capture_output=True, text=True, timeout=60)
        self.assertEqual(p.returncode, 0, p.stderr)
        p = subprocess.run([os.path.join(e2e_support.SRC, "afm"), "check", e2e_support.scene("default.yaml")],
                           capture_output=True, text=True, timeout=300)
        self.assertEqual(p.returncode, 0, p.stderr)
        self.assertIn("is a valid scene", p.stdout)


class BadCommandLines(unittest.TestCase):
    """Each program of a run reads its command line through one table
    (common/command_line.hpp): a bad value, a missing value or an unknown
    option is refused in one line, 'PROG: --opt: why (got 'value')', exit 2,
    before anything starts (sim_afm took '--inject-drop lots' as 0 and
    fw_node '--crash-at-block abc' as block 0); --help prints the usage."""

    P = e2e_support.paths
    SIM, BRIDGE = P.SIM_AFM, P.VIEW_BRIDGE
    SEVEN = (SIM, P.FW_NODE, P.OPERATOR, P.RENDERER, P.LAUNCH, P.REPLAY, BRIDGE)

    def test_each_program_refuses_a_bad_option_in_one_line(self):
        rows = ((self.SIM, ["--scene", "s", "--out", "o", "--inject-drop", "lots"], "sim_afm: --inject-drop: wants", "'lots'"),
                (self.SIM, ["--scene", "s", "--out", "o", "--log-window", "8x"], "sim_afm: --log-window: wants", "'8x'"),
                (self.P.FW_NODE, ["--scene", "s", "--crash-at-block", "abc"], "fw_node: --crash-at-block: wants", "'abc'"),
                (self.P.FW_NODE, ["--scene", "s", "--firmware", "arm"], "fw_node: --firmware: wants host or qemu", "'arm'"),
                (self.P.OPERATOR, ["--scene"], "operator: --scene: needs a value", "FILE"),
                (self.P.RENDERER, ["--scene", "s", "--out", "o", "--writer-cpus", "1-0"], "renderer: --writer-cpus: wants", "'1-0'"),
                (self.P.LAUNCH, ["--scene", "s", "--out", "o", "--bogus"], "afm_launch: --bogus: unknown option", "--help"),
                (self.P.REPLAY, ["run", "--firmware", "arm"], "afm_replay: --firmware: wants host or qemu", "'arm'"),
                (self.BRIDGE, ["--fd", "x"], "afm_view_bridge: --fd: wants", "'x'"))
        for exe, args, head, value in rows:
            p = subprocess.run([exe, *args], capture_output=True, text=True, timeout=30)
            lines = p.stderr.splitlines()
            self.assertEqual(p.returncode, 2, (exe, args, p.stderr))
            self.assertEqual(len(lines), 1, (exe, args, p.stderr))
            self.assertTrue(lines[0].startswith(head), (args, lines[0]))
            self.assertIn(value, lines[0], args)

    def test_each_program_prints_its_usage_for_help(self):
        for exe in self.SEVEN:
            p = subprocess.run([exe, "--help"], capture_output=True, text=True, timeout=30)
            self.assertEqual(p.returncode, 0, (exe, p.stderr))
            self.assertEqual(p.stderr, "", exe)
            self.assertIn("usage: " + os.path.basename(exe), p.stdout, exe)


class OutputFolderLocked(unittest.TestCase):
    """--out is locked for a run's life: a second run into it is refused at
    once, naming the run (its pid) that holds it; the first completes; the
    folder is free again afterwards."""

    def test_a_second_run_into_the_same_folder_is_refused_at_once(self):
        text = open(e2e_support.scene("short.yaml")).read().replace("duration_s: 0.6", "duration_s: 2.0\ntime_mode: realtime")
        scene = e2e_support.write_scene(text, "lock")
        out = os.path.join(os.path.dirname(scene), "out")
        self.addCleanup(e2e_support.cleanup, os.path.dirname(scene))
        first = subprocess.Popen([e2e_support.IN_NETNS, e2e_support.LAUNCH, "--scene", scene, "--out", out, "--quiet"],
                                 stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        try:
            deadline = time.time() + 20
            while not os.path.exists(os.path.join(out, "bus.lcmlog")) and time.time() < deadline:
                time.sleep(0.05)
            t0 = time.monotonic()
            code, _, stderr, _ = e2e_support.run(scene, out)
            took = time.monotonic() - t0
            lines = [l for l in stderr.splitlines() if l.strip()]
            self.assertEqual(code, 2, stderr)
            self.assertEqual(len(lines), 1, stderr)
            self.assertIn("in use by another run", lines[0])
            self.assertIn("pid ", lines[0])
            self.assertLess(took, 5.0)
            so, se = first.communicate(timeout=60)
            self.assertEqual(first.returncode, 0, se)
            # the first run removed its lock as it ended; the refused one left it alone
            self.assertFalse(os.path.exists(os.path.join(out, ".afm-run.lock")), sorted(os.listdir(out)))
        finally:
            if first.poll() is None:
                first.kill()
        with open(os.path.join(out, "run.json")) as f:
            self.assertEqual(json.load(f)["status"], "ok")   # the second run changed nothing of the first's
        code, _, stderr, _ = e2e_support.run(e2e_support.scene("short.yaml"), out)
        self.assertEqual(code, 0, stderr)   # free again


class ProcessDies(unittest.TestCase):
    def test_dead_firmware_node_stops_the_run_and_keeps_the_log(self):
        out = e2e_support.tmpdir("crash")
        code, _, stderr, rj = e2e_support.run(e2e_support.scene("short.yaml"), out, "--inject-crash", "fw_node:100")
        self.assertNotEqual(code, 0)
        self.assertIn("fw_node died with exit code 70", stderr)
        self.assertIsNotNone(rj, "run.json must be written on failure")
        self.assertEqual(rj["status"], "failed")
        codes = {p["name"]: p["exit_code"] for p in rj["processes"]}
        self.assertEqual(codes["fw_node"], 70)
        self.assertGreater(os.path.getsize(os.path.join(out, "bus.lcmlog")), 0)
        self.assertGreater(rj["channels"]["AFM_ANALOG"], 0)
        e2e_support.cleanup(out)


class BusGuard(unittest.TestCase):
    def test_launcher_refuses_the_hosts_namespace(self):
        route = subprocess.run(["ip", "route", "get", "239.255.76.67"], capture_output=True, text=True).stdout
        if " dev lo " in route:
            self.skipTest("this namespace routes multicast on loopback: the guard would allow it")
        out = e2e_support.tmpdir("guard")
        p = subprocess.run([e2e_support.LAUNCH, "--scene", e2e_support.scene("short.yaml"), "--out", out],
                           capture_output=True, text=True, timeout=60)
        self.assertEqual(p.returncode, 2)
        self.assertTrue("would leave through" in p.stderr or "no route" in p.stderr, p.stderr)
        self.assertEqual(os.listdir(out), [], "nothing may start outside the run's namespace")
        e2e_support.cleanup(out)


if __name__ == "__main__":
    e2e_support.main()
