#!/usr/bin/env python3
"""./afm faults: the fault matrix. Runs a short scene undisturbed, then once
per fault, and prints one row each: the fault, what the bench did, whether
the bus log and run.json were kept whole, and whether the run's results
match the undisturbed run where they should.

    faults/faults.py [--only ROW...] [--scene SCENE] [--out DIR] [--seed N] [--list]

Rows (design.md, "Reliability"):
  kill:NAME       SIGKILL of sim_afm, fw_node, operator or renderer at a random
                  time in the run: the run fails naming it; log and run.json kept
  stop:NAME       SIGSTOP for 2 s, then SIGCONT: the run completes, same trajectories
  launcher:SIG    SIGINT or SIGTERM to the launcher: every child stopped (checked
                  by process group), run.json says interrupted, the log closed,
                  the video (if one was begun) closed so that it opens
  launcher:SIGKILL  SIGKILL of the launcher (nothing to catch): every process of
                  the run goes with it (bound to it, PR_SET_PDEATHSIG: none left
                  by pid, process group or network namespace), no run.json; the
                  next launcher on that folder says in one line that the run there
                  was interrupted, and completes
  net:drop        10 % of the analog blocks' first sends dropped (sim_afm's
                  --inject-drop): resends, same trajectories
  net:dup         every message echoed once more, 0-5 ms later, by a process on
                  the bus (duplicates, and reordering against what follows):
                  same trajectories
  net:kernel      the kernel drops 1 % of the lockstep's datagrams (AFM_ANALOG,
                  AFM_CMD, HAPTIC_FORCE, HAPTIC_POSE: the ones a resend repairs),
                  duplicates 2 % and holds back 10 % of every channel's behind the
                  next datagram (at most 1 ms): an iptables NFQUEUE rule on the run's
                  loopback and afm_netfault's verdicts. Same trajectories, complete log
  net:netem       tc netem on the run's loopback (drop, duplicate, reorder), where
                  the kernel has sch_netem (skipped, with the reason, where not:
                  net:kernel does the same through netfilter)
  disk:full       the run folder on a 1 MB tmpfs (a run needs 2.4): a clear error, no run.json that
                  claims success
  scene:changed   the scene file overwritten with garbage while the run starts:
                  the run reads its own copy; same trajectories
  two-runs        two runs of the scene at once in one checkout: both complete,
                  both with the undisturbed trajectories
  board:killed    the card on its board (--firmware qemu, docs/pil.md), and
                  qemu-system-arm SIGKILLed at a random time in the run: the run
                  fails naming the card's board and the block; log and run.json kept
  board:hung      the board hangs at the run's middle block (AFM_BOARD_FAULT=hang:N):
                  the run fails within seconds naming the board as hung
  spoof:stop      faults/forge.py from a fresh socket in the run's namespace: the
  spoof:finished  launcher's "stop", the operator's "finished" (name, pid, seq
  spoof:pose      forged), a pose for block n + 1 ahead of the operator's: each
                  process takes them as foreign (the kernel's source port names
                  no process of the run that publishes the channel); exit 0, same
                  trajectories
  spoof-port:stop  faults/forge.py --spoof from a raw socket in the run's namespace
  spoof-port:pose  (CAP_NET_RAW kept for the forger alone), with the source port
  spoof-port:fix   of the process that publishes the channel: the launcher's
                  "stop" from afm_launch's port, a pose for block n + 1 from the
                  operator's, a HOST_OBJECT_FIX of particle 1 from the renderer's.
                  The check of senders admits them; the bus's MAC (the run's key,
                  bus/bus_key.hpp) does not: each is counted unproven; exit 0,
                  same trajectories
  spoof-port:WHAT:nokey  the same on a run without a key (AFM_BUS_MAC=off): what
                  the MAC holds off. Expected: the forgery is not refused (none
                  counted unproven), and the stop ends the run; the pose or the fix
                  may or may not change it (the row says which)
  planted:link    started as root, the run's user plants in its folder, once
                  the launcher is done (faults/plant.py): links to a root-only file
                  as outputs, a link to a stand-in for /etc/shadow as the report's
                  video, folder links, named pipes, a hard link; then root writes
                  the run's report: the targets are untouched, the give-back
                  removes and names each, the report holds no secret, same
                  trajectories (skipped, with the reason, when not root)
  link:clean      two hosts (--hosts 2, docs/hosts.md) over the link of
                  ./afm run's example, delay 0.2 ms and 2 % loss each way: same
                  trajectories as the undisturbed run on one namespace, and the
                  replay of its log identical
  link:down       two hosts, the link down for 0.5 s mid-run (ip link set vafm
                  down, then up with its route back): completes with the same
                  trajectories, or fails naming the link
  link:loss       two hosts, 10 % of the lockstep's datagrams lost each way on the
                  link: resends, same trajectories (or fails naming the link)
  link:reorder    two hosts, 0.2 ms delay with 0.3 ms jitter and 10 % held back
                  1 ms more: datagrams pass one another; same trajectories
  link:spoof:WHAT@SIDE  the spoof rows on two hosts, the forger in the host or
                  the afm namespace (WHAT: stop, finished, pose)
Exit status: 0 when every row is as expected, 1 otherwise.
"""
import argparse
import json
import os
import random
import shutil
import signal
import subprocess
import sys
import time

from analysis import paths
from faultrun import (LAUNCH, NOT_READY, PROCS, SPOOF_PORT, SRC, Run, alive_in_groups, beside, children, log_reads,
                      netns_of, processes, signal_live, trajectories, trajectory, video_opens)
from link_rows import LinkRows
from trust_rows import TrustRows

ROWS = ([f"kill:{p}" for p in PROCS] + [f"stop:{p}" for p in PROCS] + ["launcher:SIGINT", "launcher:SIGTERM", "launcher:SIGKILL",
                                                                        "net:drop", "net:dup",
        "net:kernel", "net:netem", "disk:full", "scene:changed", "two-runs", "board:killed", "board:hung",
        "spoof:stop", "spoof:finished", "spoof:pose"]
        + [f"spoof-port:{w}" for w in SPOOF_PORT] + [f"spoof-port:{w}:nokey" for w in SPOOF_PORT] + ["planted:link", "link:clean", "link:down", "link:loss", "link:reorder"]
        + [f"link:spoof:{w}@{side}" for w in ("stop", "finished", "pose") for side in ("host", "afm")])


class Matrix(TrustRows, LinkRows):
    def __init__(self, args):
        self.a = args
        self.rng = random.Random(args.seed)
        self.rows = []
        os.makedirs(args.out, exist_ok=True)
        with open(args.scene) as f:
            self.scene_text = f.read()
        self.scene = os.path.join(args.out, "scene.yaml")
        with open(self.scene, "w") as f:
            f.write(self.scene_text)

    def dir(self, name):
        d = os.path.join(self.a.out, name.replace(":", "-"))
        shutil.rmtree(d, ignore_errors=True)
        return d

    def baseline(self):
        r = Run(self.scene, self.dir("undisturbed")).finish()
        if r.code != 0 or not r.rj:
            sys.exit(f"faults: the undisturbed run failed (exit {r.code}): {r.stderr.strip()[-400:]}")
        self.blocks = r.rj["sim"]["blocks"]
        self.wall = r.rj["wall_seconds"]
        self.loop_wall = r.rj["sim"].get("loop_wall_seconds", 0.5 * self.wall)   # the lockstep's part of it
        self.base, _ = trajectories(r.out, self.blocks)
        return r

    def same(self, out):
        """Trajectories equal to the undisturbed run's on every block both
        logs hold. A block missing from a log (lcm-logger starved of CPU:
        run.json says log.complete false) is counted, not compared; more
        than 5 % missing is a failure of the record."""
        traj, err = trajectories(out, self.blocks)
        if traj is None:
            return False, "log does not read: " + err
        missing = 0
        for ch, _ in trajectory.CHANNELS:
            common = set(traj[ch]) & set(self.base[ch])
            missing = max(missing, len(set(self.base[ch]) - common), len(set(traj[ch]) - common))
            differ = sorted(q for q in common if traj[ch][q] != self.base[ch][q])
            if differ:
                return False, f"{ch} differs at blocks {differ[:3]}"
        if missing > 0.05 * self.blocks:
            return False, f"the log misses {missing} of {self.blocks} blocks"
        return True, "same trajectories" + (f" ({missing} blocks missing from a log, not compared)" if missing else "")

    def kept(self, r, want_status):
        """(log and run.json kept whole?, text)."""
        if r.rj is None:
            return False, "no run.json"
        if r.rj.get("status") != want_status:
            return False, f"run.json status {r.rj.get('status')!r}, expected {want_status!r}"
        if not log_reads(r.out):
            return False, "bus.lcmlog does not read"
        complete = r.rj.get("log", {}).get("complete")
        return True, "log reads, run.json " + want_status + ("" if complete is None else f", log complete {complete}")

    def add(self, fault, did, kept, kept_text, match, match_text, ok):
        self.rows.append({"fault": fault, "bench": did, "kept": kept, "kept_text": kept_text, "match": match, "match_text": match_text,
                          "ok": ok})
        if not self.a.quiet:
            print(f"  {fault:18s} {'ok ' if ok else 'BAD'}  {did}; {kept_text}; {match_text}", flush=True)

    def at_random_time(self):
        return self.rng.uniform(0.15, 0.6) * self.wall

    def during(self, name, act, too_late=lambda r: False):
        """Starts a run, waits a random time into it, and calls act(run,
        kids) while it still runs. When the run, or the process to signal,
        ended first (a loaded machine makes a run faster or slower than the
        undisturbed one), the row is run again with half the wait, three
        times at most; so is one for which too_late(finished run) says the
        signal came after the run had already finished. Returns (run, kids)."""
        wait = self.at_random_time()
        for _ in range(3):
            r = Run(self.scene, self.dir(name))
            kids = r.wait_kids()
            time.sleep(wait)
            acted = False
            if r.p.poll() is None and len(kids) == len(PROCS):
                try:
                    act(r, kids)
                    acted = True
                except ProcessLookupError:   # the process ended between the check and the signal
                    pass
            r.finish()
            if acted and not too_late(r):
                return r, kids
            wait /= 2
        return r, kids

    # ---- rows -----------------------------------------------------------
    def kill(self, name):
        r, kids = self.during(f"kill:{name}", lambda r, kids: signal_live(kids[name], signal.SIGKILL),
                              # a run that still ended ok: the process had finished its part
                              # (it may linger after the simulator's last block) before the kill
                              too_late=lambda r: r.code == 0)
        left = alive_in_groups(set(kids.values()))
        err = (r.rj or {}).get("error", "")
        did = f"exit {r.code}: {err[:70]}" if err else f"exit {r.code}"
        kept, kt = self.kept(r, "failed")
        named = name in err
        ok = r.code != 0 and kept and named and not left
        self.add(f"kill:{name}", did, kept, kt, None, "fails naming it" + ("" if named else " (NOT named)") +
                 (f"; {len(left)} processes left" if left else "; none left"), ok)

    def stop(self, name):
        def pause(r, kids):
            signal_live(kids[name], signal.SIGSTOP)
            time.sleep(2.0)
            os.kill(kids[name], signal.SIGCONT)
        r, kids = self.during(f"stop:{name}", pause)
        kept, kt = self.kept(r, "ok")
        same, st = self.same(r.out) if kept else (False, "-")
        self.add(f"stop:{name}", f"exit {r.code}, {r.rj.get('wall_seconds', 0):.1f} wall s" if r.rj else f"exit {r.code}", kept, kt, same,
                 st, r.code == 0 and kept and same)

    def launcher(self, sig_name):
        sig = getattr(signal, sig_name)
        # a signal that reaches the launcher after its children have all
        # ended finds the run complete: it says ok, and the row is run again
        r, kids = self.during(f"launcher:{sig_name}", lambda r, kids: os.kill(r.launcher_pid(), sig),
                              too_late=lambda r: r.code == 0 and (r.rj or {}).get("status") == "ok")
        left = alive_in_groups(set(kids.values()))
        kept, kt = self.kept(r, "interrupted")
        opens, vt = video_opens(r.out)
        ok = r.code == 128 + sig and kept and not left and len(kids) == len(PROCS) and opens
        self.add(f"launcher:{sig_name}", f"exit {r.code}", kept, kt, None,
                 f"{len(kids)} children stopped" + (f", {len(left)} left" if left else ", none left") + f"; {vt}", ok)

    def launcher_killed(self):
        """SIGKILL of the launcher: nothing of the run may outlive it, and
        the next run on its folder says the last one there was interrupted."""
        ns = {}

        def kill(r, kids):
            pid = r.launcher_pid()
            ns["net"] = os.readlink(f"/proc/{pid}/ns/net")
            signal_live(pid, signal.SIGKILL)
        r, kids = self.during("launcher:SIGKILL", kill, too_late=lambda r: (r.rj or {}).get("status") == "ok")
        left, deadline = [], time.monotonic() + 10
        while time.monotonic() < deadline:   # ffmpeg finishes its file once its input ends: a moment
            left = alive_in_groups(set(kids.values())) + [p for p, _, state, _, _ in processes()
                                                           if state != "Z" and ns.get("net") and netns_of(p) == ns["net"]]
            if not left:
                break
            time.sleep(0.1)
        again = Run(self.scene, r.out).finish()
        said = [line for line in again.stderr.splitlines() if "interrupted" in line]
        ok = r.rj is None and not left and len(kids) == len(PROCS) and len(said) == 1 and again.code == 0
        self.add("launcher:SIGKILL", f"exit {r.code}, " + ("no run.json" if r.rj is None else "a run.json (status "
                                                               f"{r.rj.get('status')!r})"), r.rj is None,
                 "the next run: " + (said[0].split(": ", 1)[-1][:60] if said else "said nothing of it") + f", exit {again.code}",
                 None, f"{len(kids)} children" + (f", {len(left)} left" if left else ", none left"), ok)

    def net_drop(self):
        r = Run(self.scene, self.dir("net:drop"), extra=["--inject-drop", "0.1"]).finish()
        kept, kt = self.kept(r, "ok")
        same, st = self.same(r.out) if kept else (False, "-")
        resends = (r.rj or {}).get("sim", {}).get("resends", 0)
        self.add("net:drop", f"exit {r.code}, {resends} resends", kept, kt, same, st, r.code == 0 and kept and same)

    def net_dup(self):
        echo = paths.HOSTILE

        # the echo's socket is no process of the run's: admitted anyway
        # (AFM_ADMIT_ANY_SENDER), so that the duplicates reach the inboxes
        r = Run(self.scene, self.dir("net:dup"), wrap=lambda cmd: beside([sys.executable, echo, "--echo", "1.0", "--seconds", "300"], cmd),
                env=dict(os.environ, AFM_ADMIT_ANY_SENDER="1")).finish()
        kept, kt = self.kept(r, "ok")
        same, st = self.same(r.out) if kept else (False, "-")
        self.add("net:dup", f"exit {r.code}, every message twice", kept, kt, same, st, r.code == 0 and kept and same)

    # the lockstep's channels: a datagram of theirs that is lost is sent again
    # (the simulator resends its block; the card answers a resend again)
    KERNEL_DROP = ["AFM_ANALOG", "AFM_CMD", "HAPTIC_FORCE", "HAPTIC_POSE"]

    def net_kernel(self):
        d = self.dir("net:kernel")
        os.makedirs(d, exist_ok=True)
        report = os.path.join(d, "netfault.json")
        nf = [paths.NETFAULT, "--queue", "0", "--drop", "0.01", "--dup", "0.02", "--reorder", "0.1",
              "--hold-us", "1000", "--seed", str(self.a.seed), "--drop-channels", ",".join(self.KERNEL_DROP), "--iptables",
              "--report", report]
        log = os.path.join(d, "netfault.log")
        # the run once the queue has its reader and its rules
        r = Run(self.scene, os.path.join(d, "run"), wrap=lambda cmd: beside(nf, cmd, ready_log=log),
                keep_caps="net_admin,net_raw", writes=d).finish()
        if r.code == NOT_READY:
            try:
                with open(log) as f:
                    tail = f.read().strip().splitlines()
            except OSError:
                tail = []
            said = (tail or [r.stderr.strip() or "(nothing said)"])[-1][:100]
            self.add("net:kernel", f"could not run: afm_netfault did not get ready: {said}", False, "-", None, "-", False)
            return
        try:
            with open(report) as f:
                nfr = json.load(f)
        except (OSError, ValueError):
            nfr = {}
        kept, kt = self.kept(r, "ok")
        same, st = self.same(r.out) if kept else (False, "-")
        resends = (r.rj or {}).get("sim", {}).get("resends", 0)
        acted = nfr.get("dropped", 0) > 0 and nfr.get("duplicated", 0) > 0 and nfr.get("reordered", 0) > 0
        self.add("net:kernel", f"exit {r.code}, kernel dropped {nfr.get('dropped', '?')}, duplicated {nfr.get('duplicated', '?')}, "
                               f"reordered {nfr.get('reordered', '?')} of {nfr.get('seen', '?')}; {resends} resends",
                 kept, kt, same, st, r.code == 0 and kept and same and acted and (r.rj or {}).get("log", {}).get("complete") is True)

    def net_netem(self):
        probe = subprocess.run(["unshare", "-rn", "tc", "qdisc", "add", "dev", "lo", "root", "netem", "loss", "1%"],
                               capture_output=True, text=True)
        if probe.returncode != 0:
            why = probe.stderr.strip().splitlines()[-1] if probe.stderr.strip() else "tc failed"
            self.add("net:netem", f"skipped: tc netem refused here ({why}); net:kernel stands in", True, "-", None, "-", True)
            return

        def wrap(cmd):
            q = " ".join(f"'{c}'" for c in cmd)
            return ["sh", "-c", "tc qdisc add dev lo root netem loss 2% duplicate 2% delay 1ms reorder 10% && " + q]
        r = Run(self.scene, self.dir("net:netem"), wrap=wrap).finish()
        kept, kt = self.kept(r, "ok")
        same, st = self.same(r.out) if kept else (False, "-")
        self.add("net:netem", f"exit {r.code}", kept, kt, same, st, r.code == 0 and kept and same)

    def disk_full(self):
        d = self.dir("disk:full")
        os.makedirs(d, exist_ok=True)
        # the tmpfs is mounted before the run's namespace drops its privilege
        # (inside it, with no capability, mount is refused), in a mount
        # namespace of its own (a user namespace too when not root)
        outer = ["unshare", "-m" if os.geteuid() == 0 else "-rm", "sh", "-c",
                 f"mount -t tmpfs -o size=1m tmpfs '{d}' && exec \"$@\"", "sh"]
        r = Run(self.scene, os.path.join(d, "run"), outer=outer).finish()
        # the tmpfs is gone with the mount namespace: what the run left is what
        # it printed, and whether it claimed success; the error must name
        # what it could not write (a refused mount would fail for another reason)
        err = r.stderr.strip().splitlines()
        said = err[-1][:110] if err else "(nothing on stderr)"
        claimed = "run: ok" in r.stdout
        named = any(("No space left" in e or "cannot write" in e) and "/" in e for e in err)
        ok = r.code != 0 and not claimed and named
        self.add("disk:full", f"exit {r.code}: {said}", not claimed, "no success claimed" if not claimed else "CLAIMED SUCCESS", None,
                 "-", ok)

    def scene_changed(self):
        scene = os.path.join(self.a.out, "scene-changing.yaml")
        shutil.copy(self.scene, scene)
        r = Run(scene, self.dir("scene:changed"))
        r.wait_kids()
        with open(scene, "w") as f:
            f.write("name: [this is not a scene\n")
        r.finish()
        kept, kt = self.kept(r, "ok")
        same, st = self.same(r.out) if kept else (False, "-")
        self.add("scene:changed", f"exit {r.code}, ran its own copy (scene.yaml)", kept, kt, same, st, r.code == 0 and kept and same)

    def two_runs(self):
        a = Run(self.scene, self.dir("two-runs-a"))
        b = Run(self.scene, self.dir("two-runs-b"))
        a.finish()
        b.finish()
        ka, kta = self.kept(a, "ok")
        kb, _ = self.kept(b, "ok")
        sa, sta = self.same(a.out) if ka else (False, "-")
        sb, stb = self.same(b.out) if kb else (False, "-")
        self.add("two-runs", f"exits {a.code} and {b.code}", ka and kb, kta, sa and sb, sta if sa and sb else f"{sta} / {stb}",
                 a.code == 0 and b.code == 0 and ka and kb and sa and sb)

    def board(self, how):
        """The card on its board: QEMU killed, or the board hung at the middle block."""
        name, env = f"board:{how}", dict(os.environ)
        if how == "hung":
            env["AFM_BOARD_FAULT"] = f"hang:{self.blocks // 2}"
        for attempt in range(3):
            t0 = time.monotonic()
            r = Run(self.scene, self.dir(name), extra=("--firmware", "qemu"), env=env)
            kids = r.wait_kids()
            acted = how == "hung"
            if how == "killed":   # a random time after the board has started (its log says so)
                board_log = os.path.join(r.out, "logs", "board.log")
                while r.p.poll() is None and "serving" not in (open(board_log).read() if os.path.exists(board_log) else ""):
                    time.sleep(0.01)
                # within the board's first half of the run, earlier on each retry (a kill after the run's end is no kill)
                time.sleep(self.at_random_time() * 0.5 / (attempt + 1))
                qemu = children(kids["fw_node"]).get("qemu-system-arm") if "fw_node" in kids else None
                try:
                    if qemu and r.p.poll() is None:
                        signal_live(qemu, signal.SIGKILL)
                        acted = True
                except ProcessLookupError:
                    pass
            r.finish()
            took = time.monotonic() - t0
            if acted and r.code != 0 and "at its start" not in (r.rj or {}).get("error", ""):
                break
        left = alive_in_groups(set(kids.values()))
        err = (r.rj or {}).get("error", "")
        kept, kt = self.kept(r, "failed")
        words = "exited (signal 9) at " if how == "killed" else f"hung: no answer to block {self.blocks // 2} within 2 s"   # at block N, or a fix after it
        named = "the card's board" in err and words in err
        self.add(name, f"exit {r.code} after {took:.1f} s: {err[err.find('the card'):][:60]}", kept, kt, None,
                 "fails naming the board" + ("" if named else " (NOT named)") + (f"; {len(left)} processes left" if left else "; none left"),
                 r.code != 0 and kept and named and not left)

    def run(self, only):
        for row in only:
            kind, _, arg = row.partition(":")
            if kind == "kill":
                self.kill(arg)
            elif kind == "stop":
                self.stop(arg)
            elif row == "launcher:SIGKILL":
                self.launcher_killed()
            elif kind == "launcher":
                self.launcher(arg)
            elif row == "net:drop":
                self.net_drop()
            elif row == "net:dup":
                self.net_dup()
            elif row == "net:kernel":
                self.net_kernel()
            elif row == "net:netem":
                self.net_netem()
            elif row == "disk:full":
                self.disk_full()
            elif row == "scene:changed":
                self.scene_changed()
            elif row == "two-runs":
                self.two_runs()
            elif kind == "board":
                self.board(arg)
            elif kind == "spoof":
                self.spoof(arg)
            elif kind == "spoof-port":
                what, _, nokey = arg.partition(":")
                self.spoof_port(what, key=not nokey)
            elif row == "planted:link":
                self.planted_link()
            elif row == "link:clean":
                self.link_row(row, acted=lambda r, rep: sum(v.get("delayed", 0) for v in rep.values()) > 0, replay=True)
            elif row == "link:down":
                self.link_down()
            elif row == "link:loss":
                self.link_row(row, acted=lambda r, rep: sum(v.get("dropped", 0) for v in rep.values()) > 0)
            elif row == "link:reorder":
                self.link_row(row, acted=lambda r, rep: sum(v.get("passed_earlier", 0) for v in rep.values()) > 0)
            elif row.startswith("link:spoof:"):
                what, _, side = row[len("link:spoof:"):].partition("@")
                self.link_spoof(what, side)


def main():
    from analysis import helptext
    ap = argparse.ArgumentParser(prog="./afm faults", description=helptext.text("faults") + "\n\n" + __doc__.split("\n\n")[0],
                                 epilog="\n\n".join(__doc__.split("\n\n")[1:]),
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--only", nargs="+", metavar="ROW", help="rows to run (default: all; see --list)")
    ap.add_argument("--scene", default=os.path.join(SRC, "scenes", "short.yaml"), help="the scene (default scenes/short.yaml)")
    ap.add_argument("--out", default=os.path.join(SRC, "runs", "faults"), help="folder for the runs and faults.json (default runs/faults)")
    ap.add_argument("--seed", type=int, default=1, help="seed of the random times (default 1)")
    ap.add_argument("--list", action="store_true", help="list the rows and exit")
    ap.add_argument("--quiet", action="store_true", help="print only the table")
    a = ap.parse_args()
    if a.list:
        print("\n".join(ROWS))
        return 0
    only = a.only or ROWS
    for r in only:
        if r not in ROWS:
            ap.error(f"--only: unknown row '{r}' (--list shows them)")
    if not os.access(LAUNCH, os.X_OK):
        sys.exit(f"faults: {LAUNCH} not built (./afm build)")
    m = Matrix(a)
    t0 = time.monotonic()
    if not a.quiet:
        print(f"faults: {len(only)} rows on {a.scene}; runs in {a.out}", flush=True)
    base = m.baseline()
    if not a.quiet:
        print(f"faults: undisturbed: {m.blocks} blocks in {m.wall:.2f} wall s", flush=True)
    m.run(only)
    width = max(len(r["fault"]) for r in m.rows)
    print()
    print(f"{'fault':{width}s}  {'as expected':11s}  {'what the bench did':52s}  {'log and run.json':34s}  results")
    for r in m.rows:
        print(f"{r['fault']:{width}s}  {'yes' if r['ok'] else 'NO':11s}  {r['bench'][:52]:52s}  {r['kept_text'][:34]:34s}  {r['match_text']}")
    bad = [r["fault"] for r in m.rows if not r["ok"]]
    with open(os.path.join(a.out, "faults.json"), "w") as f:
        json.dump({"scene": a.scene, "blocks": m.blocks, "undisturbed_wall_s": m.wall, "rows": m.rows,
                   "undisturbed_run": base.out, "seconds": time.monotonic() - t0}, f, indent=2)
    print(f"\nfaults: {len(m.rows) - len(bad)} of {len(m.rows)} rows as expected in {time.monotonic() - t0:.0f} s"
          + (f"; NOT: {', '.join(bad)}" if bad else "") + f" (faults.json in {a.out})")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
