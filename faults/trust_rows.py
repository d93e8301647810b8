"""The fault matrix's rows of trust (faults/faults.py; docs/faults.md): a
forged message from a fresh socket (spoof:), one with a spoofed source port
with and without the run's key (spoof-port:), links the run's user planted
(planted:link). A mixin of faults.Matrix: self.scene, dir, add, kept, same."""
import os
import subprocess
import sys
import tempfile

import plant  # faults/plant.py, beside this file
from analysis import paths
from faultrun import SPOOF_PORT, Run, beside


class TrustRows:
    def spoof(self, what):
        """faults/forge.py WHAT from a fresh socket of the run's namespace, name,
        pid and seq forged: every process takes it as foreign (senders.hpp),
        the run ends ok with the undisturbed trajectories."""
        name = f"spoof:{what}"
        forge = [sys.executable, paths.FORGE, what, "--seconds", "300"]
        r = Run(self.scene, self.dir(name), wrap=lambda cmd: beside(forge, cmd)).finish()
        kept, kt = self.kept(r, "ok")
        same, st = self.same(r.out) if kept else (False, "-")
        channel = {"stop": "AFM_HEARTBEAT", "finished": "AFM_HEARTBEAT", "pose": "HAPTIC_POSE"}[what]
        rj = r.rj or {}
        foreign = sum(sum(rj.get(p, {}).get("rejected", {}).get("foreign", {}).get(channel, {}).values())
                      for p in ("sim", "fw", "operator", "renderer"))
        self.add(name, f"exit {r.code}, {foreign} forged {channel} taken as foreign", kept, kt, same, st,
                 r.code == 0 and kept and same and foreign > 0)

    def spoof_port(self, what, key):
        """faults/forge.py WHAT --spoof PROGRAM: the source port of the run's
        own publisher, from a raw socket (CAP_NET_RAW kept for the forger:
        beside() runs the launcher without it). With the key: refused and
        counted unproven, the undisturbed trajectories. Without
        (AFM_BUS_MAC=off): nothing refuses it."""
        program, channel = SPOOF_PORT[what]
        name = f"spoof-port:{what}" + ("" if key else ":nokey")
        forge = [sys.executable, paths.FORGE, what, "--spoof", program, "--seconds", "300"]
        env = None if key else dict(os.environ, AFM_BUS_MAC="off")
        r = Run(self.scene, self.dir(name), wrap=lambda cmd: beside(forge, cmd), keep_caps="net_raw", env=env).finish()
        rj = r.rj or {}
        counted = sum(rj.get(p, {}).get("rejected", {}).get("unproven", {}).get("by_channel", {}).get(channel, 0)
                      for p in ("sim", "fw", "operator", "renderer"))
        counted += rj.get("launcher", {}).get("unproven", {}).get("by_channel", {}).get(channel, 0)
        if key:
            kept, kt = self.kept(r, "ok")
            same, st = self.same(r.out) if kept else (False, "-")
            self.add(name, f"exit {r.code}, {counted} forged {channel} refused (no proof)", kept, kt, same, st,
                     r.code == 0 and kept and same and counted > 0)
            return
        status = rj.get("status", "no run.json")
        same, st = self.same(r.out) if rj else (False, "no run.json")
        took = r.code != 0 if what == "stop" else True
        self.add(name, f"exit {r.code}, status {status}, {counted} refused without a key", bool(rj), "run.json " + str(status),
                 same, st + ("" if same else " (the forgery acted)"), counted == 0 and took and rj.get("launcher", {}).get("bus_mac") is False)

    def planted_link(self):
        """faults/plant.py's links, pipes and hard link in the run's folder,
        planted by the run's user; root's give-back and report follow none."""
        name = "planted:link"
        if os.geteuid() != 0:
            self.add(name, "skipped: not root (the run's user is the caller's own)", True, "-", None, "-", True)
            return
        top = self.dir("planted-targets")
        os.makedirs(top, mode=0o700, exist_ok=True)
        t = plant.targets(tempfile.mkdtemp(dir=top))
        out = self.dir(name)
        try:
            r = Run(self.scene, out, wrap=lambda cmd: ["sh", "-c", plant.SCRIPT, *cmd], env=plant.environ(out, t)).finish()
            report = subprocess.run([sys.executable, "-m", "analysis.run_report", out], capture_output=True, text=True, timeout=300)
            try:
                with open(os.path.join(out, "report.html"), errors="replace") as f:
                    leaked = plant.SECRET_MARK in f.read()
            except OSError:
                leaked = False
            named = [n for n in plant.PLANTED if f"removed {os.path.join(out, n)} (" in r.stderr]
            changed = plant.untouched(t) + plant.left_behind(out)
        finally:
            plant.forget(t)
        kept, kt = self.kept(r, "ok")
        same, st = self.same(r.out) if kept else (False, "-")
        did = (f"exit {r.code}, {len(named)} of {len(plant.PLANTED)} planted removed and named, report exit {report.returncode}"
               + (", the secret IN the report" if leaked else "") + (f"; CHANGED: {changed[0]}" if changed else "; targets untouched"))
        self.add(name, did, kept, kt, same, st,
                 r.code == 0 and kept and same and report.returncode == 0 and not leaked and not changed and len(named) == len(plant.PLANTED))
