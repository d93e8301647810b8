"""./afm's entry to the live view (docs/view.md):

    python -m analysis.view run --out DIR [--wait] [--port N] -- AFM_LAUNCH [ARGS...]
    python -m analysis.view play RUN_DIR [--port N]

`run` serves the page of a run it starts (./afm run SCENE --view); `play`
serves a recorded run's (./afm view RUN_DIR) until Ctrl-C. Both listen on
127.0.0.1 only and print the page's address with its token.
"""
import argparse
import asyncio
import signal
import sys

from analysis.text import printable
from analysis.view import live, recorded, server


def _parser():
    ap = argparse.ArgumentParser(prog="python -m analysis.view", description=__doc__.split("\n\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("run", help="serve the page of a run it starts (./afm run SCENE --view)")
    r.add_argument("--out", required=True, help="the run's folder (for run.json at the end)")
    r.add_argument("--wait", action="store_true", help="start the run only once a page has connected")
    r.add_argument("--port", type=int, default=0, help="port on 127.0.0.1 (default: any free one)")
    r.add_argument("launch", nargs=argparse.REMAINDER, help="-- afm_launch and its arguments")
    p = sub.add_parser("play", help="serve a recorded run's page (./afm view RUN_DIR)")
    p.add_argument("run_dir")
    p.add_argument("--port", type=int, default=0, help="port on 127.0.0.1 (default: any free one)")
    return ap


async def _play(source, sock):
    view = server.ViewServer(server.new_token(), source)
    await view.start(sock)
    print(f"view: {server.url(sock, view.token)}", file=sys.stderr)
    print(f"view: {len(source.frames)} frames of {source.run_dir}; Ctrl-C stops", file=sys.stderr, flush=True)
    stop = asyncio.Event()
    asyncio.get_running_loop().add_signal_handler(signal.SIGINT, stop.set)
    asyncio.get_running_loop().add_signal_handler(signal.SIGTERM, stop.set)
    await stop.wait()
    await view.stop(0)


def main(argv=None):
    try:
        return _main(argv)
    except server.ListenError as e:   # --port 99999, or a port another process holds: one line
        print(e, file=sys.stderr)
        return 2


def _main(argv):
    a = _parser().parse_args(argv)
    if a.cmd == "run":
        cmd = a.launch[1:] if a.launch[:1] == ["--"] else a.launch
        if not cmd:
            sys.exit("view: run: no command after --")
        return live.main(cmd, a.out, wait=a.wait, port=a.port)
    sock = server.listen(a.port)   # a port that cannot be had is named before the record is read
    try:
        source = recorded.RecordedSource(a.run_dir)
    except recorded.RunError as e:
        sock.close()
        print(printable(str(e)), file=sys.stderr)   # the folder's name, escaped
        return 2
    asyncio.run(_play(source, sock))
    return 0


if __name__ == "__main__":
    sys.exit(main())
