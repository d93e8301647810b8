"""The fault matrix's rows on two hosts (faults/faults.py; docs/hosts.md):
the link clean, down, lossy and reordering, and the spoof rows across it.
A mixin of faults.Matrix: self.scene, dir, add, kept, same, wall, loop_wall."""
import os
import subprocess
import sys

from analysis import paths
from faultrun import DROP_CAPS, LINK_BUS_URL, LINKS, Run, beside


class LinkRows:
    def link_said(self, r):
        """What run.json says of the link: shaper, delay achieved, datagrams lost, resends."""
        rj = r.rj or {}
        link = rj.get("hosts", {}).get("link", {})
        ach = link.get("achieved", {})
        rep = link.get("shaper_reports", {})
        lost = sum(v.get("dropped", 0) for v in rep.values())
        seen = sum(v.get("seen", 0) for v in rep.values())
        med = [ach.get(d, {}).get("median_us") for d in ("to_afm", "to_host")]
        delay = "/".join("?" if m is None else f"{m:.0f}" for m in med)
        return (f"{link.get('shaper', '?')}, {delay} us one-way, {lost} of {seen} datagrams lost, "
                f"{rj.get('sim', {}).get('resends', '?')} resends"), rep

    def names_link(self, r):
        err = (r.rj or {}).get("error", "") or r.stderr
        return "link" in err

    def link_row(self, name, env=None, acted=lambda r, rep: True, replay=False):
        """A run on two hosts over LINKS[name]: as expected when it completes with
        the undisturbed (one-namespace) trajectories, or fails naming the link;
        acted(run, shaper reports) says the link did what the row is about."""
        r = Run(self.scene, self.dir(name), env=env, link=LINKS[name]).finish()
        said, rep = self.link_said(r)
        did = acted(r, rep)
        if r.code == 0:
            kept, kt = self.kept(r, "ok")
            same, st = self.same(r.out) if kept else (False, "-")
            if replay and same:
                p = subprocess.run([paths.REPLAY, r.out], capture_output=True, text=True)
                same, st = p.returncode == 0, st + ("; replay identical" if p.returncode == 0 else f"; replay exit {p.returncode}")
            ok = kept and same and did
        else:
            kept, kt = self.kept(r, "failed")
            same, st = None, "fails naming the link" if self.names_link(r) else "fails WITHOUT naming the link"
            ok = kept and self.names_link(r) and did
        self.add(name, f"exit {r.code}: {said}" + ("" if did else " (the link did NOT act)"), kept, kt, same, st, ok)

    def link_down(self):
        # mid-run: a fifth into the lockstep of the same run on two hosts, timed
        # undisturbed first (the lockstep starts at the launcher's wall time less
        # the loop's; before it, the first scan, slower across the link)
        t = Run(self.scene, self.dir("link:down-timing"), link=LINKS["link:down"]).finish()
        sim = (t.rj or {}).get("sim", {})
        wall, loop = (t.rj or {}).get("wall_seconds", self.wall), sim.get("loop_wall_seconds", self.loop_wall)
        at = max(0.3, wall - loop + 0.2 * loop)
        env = dict(os.environ, AFM_LINK_DOWN=f"{at:.2f}:0.5")

        def acted(r, rep):   # down and up again (or the run failed meanwhile), and the lockstep felt it
            down = (r.rj or {}).get("hosts", {}).get("link", {}).get("down", "")
            return "down" in down and (r.code != 0 or ("up" in down and (r.rj or {}).get("sim", {}).get("resends", 0) >= 10))
        self.link_row("link:down", env=env, acted=acted)

    def link_spoof(self, what, side):
        """spoof:WHAT on two hosts, the forger in the host or the afm namespace."""
        name = f"link:spoof:{what}@{side}"
        forge = ["env", f"LCM_DEFAULT_URL={LINK_BUS_URL}", f"AFM_BUS_LINK=v{side}", DROP_CAPS, sys.executable,
                 paths.FORGE, what, "--seconds", "300"]
        if side == "afm":   # entered without privilege: the run's uid owns the afm namespace (docs/hosts.md)
            forge = ["sh", "-c", 'exec nsenter -t "$AFM_HOSTS_AFM_PID" -U -n --preserve-credentials "$@"', "forge", *forge]
        r = Run(self.scene, self.dir(name), wrap=lambda cmd: beside(forge, cmd), link=LINKS["spoof"]).finish()
        kept, kt = self.kept(r, "ok")
        same, st = self.same(r.out) if kept else (False, "-")
        channel = {"stop": "AFM_HEARTBEAT", "finished": "AFM_HEARTBEAT", "pose": "HAPTIC_POSE"}[what]
        rj = r.rj or {}
        foreign = {p: sum(rj.get(p, {}).get("rejected", {}).get("foreign", {}).get(channel, {}).values())
                   for p in ("sim", "fw", "operator", "renderer")}
        # the forger's datagrams reach both namespaces: a heartbeat is taken as foreign by the simulator (afm) and the
        # card (host) alike; a pose by the card, its one reader
        both = foreign["fw"] > 0 and (foreign["sim"] > 0 or channel == "HAPTIC_POSE")
        self.add(name, f"exit {r.code}, forged {channel} foreign: " + ", ".join(f"{p} {n}" for p, n in foreign.items()), kept, kt, same,
                 st, r.code == 0 and kept and same and both)
