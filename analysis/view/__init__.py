"""The live view in a browser (docs/view.md): `./afm run SCENE --view`
serves a page that shows the run as the renderer composes it, and
`./afm view RUN_DIR` plays a recorded run in the same page.

- server: the page's HTTP server (aiohttp): the static files, one WebSocket,
  the token; its sources of frames (live, recorded).
- live: a viewed run: the listening socket in the caller's namespace, the
  run in its own, the bridge's pipe between them.
- recorded: a run's folder read back (bus.lcmlog through analysis.afmlog,
  frames/*.png).
"""
