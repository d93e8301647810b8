"""End to end: a short scene through all four processes on the bus, checked
from the recorded log (issue 2): every channel present; each particle's final
modelled position within 5 nm of the simulator's truth; frame count equal to
duration x frame rate; same seed -> same object trajectories, even when the
simulator drops analog blocks on purpose (the resend path)."""
import glob
import math
import os
import sys
import re
import subprocess
import unittest

import numpy as np
import yaml
from PIL import Image

import e2e_support
from analysis import afmlog
from analysis import gsf

TOL_NM = 5.0
TOL_MAP_NM = 0.1   # a fresh scan of a smooth measured substrate against the map


def trajectories(log):
    fw = {s: tuple((p.id, p.x_nm, p.y_nm) for p in w.particles) for s, w in afmlog.whole_by_seq(log["FW_STATE"], lambda m: m.objects).items()}
    truth = {s: tuple((p.id, p.x_nm, p.y_nm) for p in w.particles)
             for s, w in afmlog.whole_by_seq(log["SIM_TRUTH"], lambda m: m.objects).items()}
    return fw, truth


# Published only when a run is viewed (./afm run --view; test_view.py checks them).
VIEWED_ONLY = {"VIEW_FRAME"}


class EndToEnd(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.scene = e2e_support.scene("short.yaml")
        with open(cls.scene) as f:
            cls.spec = yaml.safe_load(f)
        cls.out1 = e2e_support.tmpdir("e2e1")
        cls.out2 = e2e_support.tmpdir("e2e2")
        cls.out3 = e2e_support.tmpdir("e2e3")
        cls.r1 = e2e_support.run(cls.scene, cls.out1)
        cls.r2 = e2e_support.run(cls.scene, cls.out2)
        cls.r3 = e2e_support.run(cls.scene, cls.out3, "--inject-drop", "0.05")
        cls.log1 = afmlog.load(os.path.join(cls.out1, "bus.lcmlog"))

    @classmethod
    def tearDownClass(cls):
        e2e_support.cleanup(cls.out1, cls.out2, cls.out3)

    def test_run_exits_zero_with_every_process_clean(self):
        code, _, err, rj = self.r1
        self.assertEqual(code, 0, err)
        self.assertEqual(rj["status"], "ok")
        for p in rj["processes"]:
            self.assertEqual(p["exit_code"], 0, p)
        for key in ("scene", "seed", "sim_seconds", "wall_seconds", "frames", "processes", "channels"):
            self.assertIn(key, rj)
        self.assertAlmostEqual(rj["sim_seconds"], self.spec["duration_s"], places=6)

    def test_run_json_timing_is_the_loops_first_block_to_last(self):
        _, out, _, rj = self.r1
        t, sim = rj["timing"], rj["sim"]
        self.assertEqual(t["loop_seconds"], sim["loop_wall_seconds"])
        self.assertEqual(t["loop_blocks"], sim["blocks"])
        self.assertAlmostEqual(t["loop_simulated_seconds"], sim["blocks"] / self.spec["block_hz"], places=9)
        self.assertAlmostEqual(t["loop_realtime_factor"], t["loop_simulated_seconds"] / t["loop_seconds"], places=9)
        self.assertAlmostEqual(t["loop_us_per_block"], t["loop_seconds"] / sim["blocks"] * 1e6, places=6)
        self.assertGreater(t["outside_loop_seconds"], 0)   # the processes' start and the first scan come before the loop
        self.assertAlmostEqual(t["whole_seconds"], rj["wall_seconds"], places=9)
        self.assertEqual(t["whole_realtime_factor"], rj["sim_seconds_per_wall_second"])
        self.assertLess(t["whole_realtime_factor"], t["loop_realtime_factor"])
        self.assertIn("run: the loop, first block to last:", out)

    def test_every_channel_is_in_the_log(self):
        for ch in afmlog.CHANNELS:
            if ch in VIEWED_ONLY:
                self.assertEqual(len(self.log1.get(ch, [])), 0, f"{ch} in the log of a run nobody viewed")
                continue
            self.assertGreater(len(self.log1.get(ch, [])), 0, f"no {ch} in the log")
        blocks = round(self.spec["duration_s"] * self.spec["block_hz"])
        self.assertEqual(len(afmlog.by_seq(self.log1["AFM_ANALOG"])), blocks)
        self.assertEqual(len(afmlog.by_seq(self.log1["FW_STATE"])), blocks)

    def test_run_json_counts_match_the_log(self):
        rj = self.r1[3]
        for ch in afmlog.CHANNELS:
            self.assertEqual(rj["channels"].get(ch, 0), len(self.log1[ch]), ch)

    def test_what_went_aside_is_all_in_the_log(self):
        # bus/aside.hpp: the observers' channels are published from a
        # thread of the card's and the simulator's own; every one the
        # process counted is in the record, none failed
        import json
        with open(os.path.join(self.out1, "fw_report.json")) as f:
            fw = json.load(f)["aside"]
        with open(os.path.join(self.out1, "sim_report.json")) as f:
            sim = json.load(f)["aside"]
        self.assertEqual(fw["failed"], 0, fw)
        self.assertEqual(sim["failed"], 0, sim)
        self.assertEqual(fw["published"], len(self.log1["FW_STATE"]), fw)
        self.assertEqual(sim["published"], len(self.log1["SIM_TRUTH"]), sim)

    def test_final_model_within_5nm_of_truth(self):
        fw, truth = trajectories(self.log1)
        last = max(fw)
        self.assertEqual(last, max(truth))
        truth_by_id = {i: (x, y) for i, x, y in truth[last]}
        moved = 0
        for i, x, y in fw[last]:
            tx, ty = truth_by_id[i]
            err = math.hypot(x - tx, y - ty)
            print(f"particle {i}: model ({x:.2f}, {y:.2f}) truth ({tx:.2f}, {ty:.2f}) error {err:.3f} nm")
            self.assertLess(err, TOL_NM, f"particle {i}")
        first_truth = {i: (x, y) for i, x, y in truth[min(truth)]}
        for i, (x, y) in truth_by_id.items():
            if math.hypot(x - first_truth[i][0], y - first_truth[i][1]) > 50:
                moved += 1
        self.assertGreaterEqual(moved, 1, "the scene must actually push a particle")

    def test_frame_count_is_duration_times_frame_rate(self):
        expected = round(self.spec["duration_s"] * self.spec["frame_rate_hz"])
        pngs = glob.glob(os.path.join(self.out1, "frames", "*.png"))
        self.assertEqual(len(pngs), expected)
        self.assertEqual(self.r1[3]["frames"], expected)
        self.assertEqual(len({m.index for m in self.log1["RENDER_FRAME"]}), expected)
        self.assertTrue(os.path.getsize(os.path.join(self.out1, "video.mp4")) > 0)

    def test_pngs_read_with_another_decoder(self):
        # the PNG files are the bench's own (host/png_file.hpp): Pillow,
        # which does not use libpng, checks every chunk's CRC and reads them
        # frames at least 512 px, each display pixel a whole square (renderer/frame_overlay.hpp)
        image_px = self.spec["outputs"]["image_px"]
        px = self.r1[3]["renderer"]["frame_px"]
        self.assertGreaterEqual(px, 512)
        self.assertEqual(px % image_px, 0)
        paths = sorted(glob.glob(os.path.join(self.out1, "frames", "*.png")))
        paths += [os.path.join(self.out1, n) for n in ("scan_initial.png", "fidelity_diff.png", "contact_sheet.png")]
        for p in paths:
            with Image.open(p) as im:
                im.verify()
            with Image.open(p) as im:
                im.load()
                self.assertEqual(im.mode, "RGB", p)
                if "frame_" in p:
                    self.assertEqual(im.size, (px, px), p)

    def test_video_decodes_to_the_frame_count(self):
        expected = round(self.spec["duration_s"] * self.spec["frame_rate_hz"])
        out = subprocess.run([e2e_support.paths.MEDIA, "frames",
                              os.path.join(self.out1, "video.mp4")], capture_output=True, text=True, check=True).stdout.split()
        self.assertEqual(int(out[0]), expected)
        self.assertEqual(int(out[1]), self.r1[3]["renderer"]["frame_px"])
        self.assertTrue(os.path.getsize(os.path.join(self.out1, "contact_sheet.png")) > 0)

    def test_fidelity_against_a_fresh_scan(self):
        fid = self.r1[3]["fidelity"]
        print(f"fidelity: max {fid['max_position_error_nm']:.3f} nm, rms {fid['rms_height_error_nm']:.3f} nm")
        self.assertLess(fid["max_position_error_nm"], TOL_NM)
        self.assertTrue(fid["pass"])
        self.assertEqual(sorted(o["id"] for o in fid["objects"]), sorted(p["id"] for p in self.spec["objects"]["particles"]))
        for o in fid["objects"]:
            self.assertTrue(o["found"], o)

    def test_gsf_files_round_trip_with_physical_size(self):
        px = self.spec["outputs"]["image_px"]
        side_m = self.spec["sample"]["field_nm"] * 1e-9
        grids = {}
        for name in ("scan_initial", "scan_final", "display_final"):
            header, rows = gsf.read(os.path.join(self.out1, name + ".gsf"))
            self.assertEqual((int(header["XRes"]), int(header["YRes"])), (px, px), name)
            self.assertAlmostEqual(float(header["XReal"]), side_m, delta=side_m * 1e-6)
            self.assertAlmostEqual(float(header["YReal"]), side_m, delta=side_m * 1e-6)
            self.assertEqual(header["XYUnits"], "m")
            self.assertEqual(header["ZUnits"], "m")
            grids[name] = rows
        top = max(max(r) for r in grids["scan_initial"])
        self.assertAlmostEqual(top, 100e-9, delta=2e-9)   # 100 nm latex: tip-dilated, same top
        # The RMS difference recomputed from the files equals the renderer's.
        n = px * px
        rms = math.sqrt(sum((a - b) ** 2 for ra, rb in zip(grids["display_final"], grids["scan_final"])
                            for a, b in zip(ra, rb)) / n) * 1e9
        self.assertAlmostEqual(rms, self.r1[3]["fidelity"]["rms_height_error_nm"], delta=1e-3)

    def test_gwyddion_opens_the_gsf_with_the_physical_size(self):
        # Gwyddion's own loader (its thumbnailer) reads the file and records
        # the size it understood in the thumbnail's metadata.
        thumb = os.path.join(self.out1, "thumb.png")
        p = subprocess.run(["gwyddion-thumbnailer", "gnome2", "128", os.path.join(self.out1, "scan_final.gsf"), thumb],
                           capture_output=True, text=True, timeout=60)
        self.assertEqual(p.returncode, 0, p.stderr)
        info = Image.open(thumb).info
        px = self.spec["outputs"]["image_px"]
        side_um = self.spec["sample"]["field_nm"] / 1000
        self.assertEqual(info["Thumb::Image::Width"], str(px))
        self.assertEqual(info["Thumb::Image::Height"], str(px))
        real = info["Thumb::X-Gwyddion::RealSize"]
        print("Gwyddion reads:", real)
        m = re.fullmatch(r"([0-9.]+)\u00d7([0-9.]+) (nm|\u00b5m|mm)", real)
        self.assertIsNotNone(m, real)
        scale = {"nm": 1e-3, "\u00b5m": 1.0, "mm": 1e3}[m.group(3)]
        self.assertAlmostEqual(float(m.group(1)) * scale, side_um, delta=side_um * 1e-3)
        self.assertAlmostEqual(float(m.group(2)) * scale, side_um, delta=side_um * 1e-3)

    def test_log_is_complete(self):
        self.assertTrue(self.r1[3]["log"]["complete"], self.r1[3]["log"])

    def test_log_ends_with_every_process_done(self):
        # the launcher closes the record once the bus has been quiet for
        # kQuietMs after every process exited: what each sent last (its
        # "done", after its last block) is in it
        done = {m.name for m in self.log1["AFM_HEARTBEAT"] if m.state == "done"}
        self.assertEqual(done, {"sim_afm", "fw_node", "operator", "renderer"})
        frames = self.log1["RENDER_FRAME"]
        self.assertTrue(frames)
        self.assertEqual(max(m.index for m in frames), self.r1[3]["frames_expected"] - 1)

    def test_same_seed_same_trajectories(self):
        self.assertEqual(self.r2[0], 0, self.r2[2])
        log2 = afmlog.load(os.path.join(self.out2, "bus.lcmlog"))
        fw1, t1 = trajectories(self.log1)
        fw2, t2 = trajectories(log2)
        self.assertEqual(fw1, fw2)
        self.assertEqual(t1, t2)

    def test_same_seed_same_frames(self):
        # the renderer runs up to 2 frames behind the simulator, waiting only
        # at scans (scene.hpp, frames_to_wait_for): its frames must not
        # depend on how far behind it was
        def frames(out):
            paths = sorted(glob.glob(os.path.join(out, "frames", "*.png")))
            return [os.path.basename(p) for p in paths], [open(p, "rb").read() for p in paths]
        n1, f1 = frames(self.out1)
        n2, f2 = frames(self.out2)
        self.assertEqual(n1, n2)
        self.assertGreater(len(n1), 0)
        for name, a, b in zip(n1, f1, f2):
            self.assertEqual(a, b, f"{name} differs between two runs of the same scene")

    def test_each_frame_shows_its_own_block(self):
        # FW_STATE comes a batch after its block (published aside): a
        # frame waits for that of the block it fell due at
        self.assertEqual(self.r1[3]["renderer"]["frames_mixed_blocks"], 0)
        self.assertEqual(self.r2[3]["renderer"]["frames_mixed_blocks"], 0)

    def test_processes_are_placed_as_run_json_says(self):
        # common/placement.hpp: the lockstep on one CPU, the observers on the
        # others; each process's CPUs are read from the kernel once it is ready
        rj = self.r1[3]
        pl = rj["placement"]
        cpus = {p["name"]: p["cpus"] for p in rj["processes"]}
        if not pl["on"]:
            self.assertTrue(pl["why"], pl)
            mine = len(os.sched_getaffinity(0))
            self.assertTrue(mine <= 1 or "another run" in pl["why"], f"not placed with {mine} CPUs allowed: {pl['why']}")
            return
        self.assertNotEqual(pl["lockstep_cpus"], pl["observer_cpus"])
        for name in ("sim_afm", "fw_node", "operator"):
            self.assertEqual(cpus[name], pl["lockstep_cpus"], name)
        self.assertEqual(cpus["renderer"], pl["observer_cpus"])

    def test_lost_blocks_are_resent_and_change_nothing(self):
        code, _, err, rj = self.r3
        self.assertEqual(code, 0, err)
        self.assertGreater(rj["sim"]["injected_drops"], 0)
        self.assertGreaterEqual(rj["sim"]["resends"], rj["sim"]["injected_drops"])
        log3 = afmlog.load(os.path.join(self.out3, "bus.lcmlog"))
        fw1, t1 = trajectories(self.log1)
        fw3, t3 = trajectories(log3)
        self.assertEqual(fw1, fw3)
        self.assertEqual(t1, t3)


class FromANotebook(unittest.TestCase):
    """The project's Python is installed in the venv: a script run with the
    venv's python alone, from another folder and with no PYTHONPATH or AFM_*
    variable, reads a run's forces as arrays (issue 33)."""

    def test_the_venvs_python_reads_a_runs_forces_as_arrays(self):
        out = e2e_support.tmpdir("notebook")
        self.addCleanup(e2e_support.cleanup, out)
        code, _, err, _ = e2e_support.run(e2e_support.scene("short.yaml"), out)
        self.assertEqual(code, 0, err)
        script = ("from analysis import afmlog\n"
                  f"log = afmlog.load({os.path.join(out, 'bus.lcmlog')!r})\n"
                  "f = afmlog.column(log['FW_STATE'], 'force_nN')\n"
                  "s = afmlog.column(log['FW_STATE'], 'seq')\n"
                  "print(f.shape[0], f.shape[1], s.shape[0], type(f).__module__)\n")
        env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH" and not k.startswith("AFM_")}
        p = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, cwd="/", env=env, timeout=120)
        self.assertEqual(p.returncode, 0, p.stderr)
        n, three, n_seq, module = p.stdout.split()
        self.assertGreater(int(n), 500)
        self.assertEqual(three, "3")
        self.assertEqual(n, n_seq)
        self.assertEqual(module, "numpy")


class MeasuredSubstrate(unittest.TestCase):
    """A scene on a measured substrate (sample.substrate: {gsf: FILE}): the
    fresh scan at the run's end reproduces the map. The map is smooth (a
    10 nm hill 400 nm wide on a gentle slope), so the tip's dilation and the
    bilinear interpolation between its 37.5 nm pixels stay far below the
    tolerance."""

    @staticmethod
    def hill_nm(x, y):
        return 10.0 * np.exp(-(x ** 2 + (y - 200.0) ** 2) / (2 * 400.0 ** 2)) + 0.002 * x

    def write_map(self, path, n=65, side_nm=2400.0):
        # a GSF written from the format's description (not the bench's writer)
        pitch = side_nm / n
        xs = -side_nm / 2 + (np.arange(n) + 0.5) * pitch
        ys = side_nm / 2 - (np.arange(n) + 0.5) * pitch          # row 0 at the top
        z = self.hill_nm(xs[None, :], ys[:, None]) * 1e-9
        head = (f"Gwyddion Simple Field 1.0\nXRes = {n}\nYRes = {n}\nXReal = {side_nm * 1e-9!r}\nYReal = {side_nm * 1e-9!r}\n"
                f"XOffset = {-side_nm / 2 * 1e-9!r}\nYOffset = {-side_nm / 2 * 1e-9!r}\nXYUnits = m\nZUnits = m\n").encode()
        head += b"\0" * (4 - len(head) % 4)
        with open(path, "wb") as f:
            f.write(head + z.astype("<f4").tobytes())

    def test_fresh_scan_reproduces_the_map(self):
        text = open(e2e_support.scene("short.yaml")).read()
        spec = yaml.safe_load(text)
        spec["name"] = "measured-substrate"
        spec["duration_s"] = 0.2
        spec["sample"]["substrate"] = {"gsf": "hill.gsf"}           # beside the scene: relative to it
        spec["effects"] = ["adhesion", "tip_convolution"]
        spec["objects"] = {"particles": []}
        spec["operator"] = {"load_nN": 5, "speed_nm_per_s": 2000, "path_nm": [[0, -700], [0, -300]]}
        spec["outputs"] = {"image_px": 64}
        path = e2e_support.write_scene(yaml.safe_dump(spec), "measured")
        self.write_map(os.path.join(os.path.dirname(path), "hill.gsf"))
        out = os.path.join(os.path.dirname(path), "out")
        code, _, err, rj = e2e_support.run(path, out, "--no-verdict")
        self.assertEqual(code, 0, err)
        self.assertIn("substrate_map", rj["sim"]["models_built"])
        header, z = gsf.read(os.path.join(out, "scan_final.gsf"))
        xs, ys = gsf.axes(header)
        want = self.hill_nm(xs[None, :] * 1e9, ys[:, None] * 1e9)
        err_nm = np.abs(z * 1e9 - want)
        print(f"measured substrate: scan_final vs the map: max {err_nm.max():.3f} nm, rms "
              f"{np.sqrt(np.mean(err_nm ** 2)):.3f} nm over {z.size} pixels (map 0..{want.max():.2f} nm)")
        self.assertGreater(np.ptp(z) * 1e9, 9.0)     # the hill is imaged, not a flat plane
        self.assertLess(err_nm.max(), TOL_MAP_NM)
        e2e_support.cleanup(os.path.dirname(path))


class RealTime(unittest.TestCase):
    """time_mode: realtime paces the same lockstep loop by the wall clock."""

    def test_realtime_takes_at_least_the_simulated_time(self):
        text = open(e2e_support.scene("short.yaml")).read().replace("seed: 7", "seed: 7\ntime_mode: realtime")
        path = e2e_support.write_scene(text, "realtime")
        out = os.path.join(os.path.dirname(path), "out")
        code, _, err, rj = e2e_support.run(path, out)
        self.assertEqual(code, 0, err)
        loop = rj["sim"]["loop_wall_seconds"]
        print(f"realtime: {rj['sim_seconds']:.2f} simulated s in a {loop:.2f} s loop")
        self.assertGreaterEqual(loop, rj["sim_seconds"] * 0.99)
        self.assertLess(loop, rj["sim_seconds"] + 2.0)
        self.assertLessEqual(rj["timing"]["loop_realtime_factor"], 1.01)   # paced: never ahead of real time
        e2e_support.cleanup(os.path.dirname(path))


if __name__ == "__main__":
    e2e_support.main()
