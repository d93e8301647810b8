"""./afm calib tilted --loops (analysis/loops.py): friction loops from a
researcher's own CSV files to mu and k_theta K_l / h with their
uncertainty, through the firmware's own solver. Loops drawn from eq. 16-17
with the paper's constants and a known noise: the slopes and the
calibration come back within their stated errors; bad files are named by
file, line and column."""
import json
import math
import os
import subprocess
import sys
import unittest

import numpy as np

import benchtest

AFM = os.path.join(os.environ["AFM_SOURCE"], "afm")
CALC = os.path.join(benchtest.BUILD, "host_bridge", "calc", "afm_calc")
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


def flags():
    return ["--angle-deg", PAPER["phi"], "--spring-N-per-m", PAPER["kn"], "--deflection-nm-per-V", PAPER["Kn"]]


class Loops(unittest.TestCase):
    def setUp(self):
        self.dir = benchtest.tmpdir("loops")
        self.addCleanup(benchtest.cleanup, self.dir)

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

    def test_the_afm_entry_point_routes_loops(self):
        files = write_loops(self.dir, [0.5, 1.0, 1.5], noise_v=0.002)
        p = subprocess.run([AFM, "calib", "tilted", "--loops", *files, *map(str, flags())], capture_output=True, text=True,
                           timeout=600)
        self.assertEqual(p.returncode, 0, p.stderr)
        self.assertIn("mu = 0.08", p.stdout)
        self.assertIn("+-", p.stdout)


if __name__ == "__main__":
    unittest.main(verbosity=2)
