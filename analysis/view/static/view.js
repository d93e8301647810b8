// The live view's page (docs/view.md): one WebSocket to the server that
// served this file; draws each frame the renderer composed (never an image
// of its own), the tip, the force, the flags, the objects' ids, a strip
// chart and the progress. window.afmView holds what the page shows, for
// the browser test (tests/e2e/test_view.py).
"use strict";
(function () {
  const CHART_S = 5;                        // the strip chart's span, simulated seconds
  const token = new URLSearchParams(location.search).get("token") || "";
  const $ = (id) => document.getElementById(id);
  const img = $("image").getContext("2d"), glyph = $("glyph").getContext("2d"), chart = $("chart").getContext("2d");
  const state = window.afmView = {
    connected: false, mode: "", framesShown: 0, lastIndex: -1, framesTotal: 0, skippedRenderer: 0,
    skippedServer: 0, skippedPage: 0, chartSamples: 0, chartT: [], ended: null, flags: {}, t: 0,
    painted: [],                            // per frame painted (./afm bench view), wall ms: [block, painted,
                                            //  server had it, server sent it, page had it, page drew it]
    hand: null,                             // operator.mode browser: {target_nm, load_nN, engaged, sent}
  };
  const HAND_SEND_MS = 20;                  // the pointer's commands, at most this often
  const series = { t: [], fx: [], fy: [], fz: [], hx: [], hy: [], hz: [] };
  let meta = null, decoding = false, next = null, playing = false, lastMeta = null;

  const ws = new WebSocket((location.protocol === "https:" ? "wss://" : "ws://") + location.host +
                           "/ws?token=" + encodeURIComponent(token));
  ws.binaryType = "arraybuffer";
  ws.onopen = () => { state.connected = true; $("status").textContent = "connected"; };
  ws.onclose = () => { state.connected = false; if (!state.ended) $("status").textContent = "disconnected"; };
  ws.onmessage = (ev) => (typeof ev.data === "string" ? onText(JSON.parse(ev.data)) : onImage(ev.data));

  function onText(m) {
    if (m.type === "hello") hello(m);
    else if (m.type === "frame") meta = m;
    else if (m.type === "status") procs(m.processes);
    else if (m.type === "end") ended(m);
    else if (m.type === "hand") enableHand(m.hand);
    else if (m.type === "push") pushNews(m);
  }

  // operator.mode browser: the pointer sets the hand's target, the wheel and
  // keys the load, the button (or space) engages and lifts; the operator's
  // device model does the rest (docs/view.md).
  function enableHand(h) {
    if (state.hand || !h) return;
    state.hand = { target_nm: null, load_nN: h.load_nN || 5, engaged: false, sent: 0, last: 0, timer: null };
    $("hand").hidden = false;
    showHand();
    const c = $("image");
    c.style.cursor = "crosshair";
    c.addEventListener("pointerdown", (e) => {
      if (e.button !== 0) return;
      if (pick.phase) { pickAt(e); return; }   // a stroke being asked for: the clicks are its particle and target
      if (pick.busy) return;                    // a stroke drives the tip: the hand waits
      c.setPointerCapture(e.pointerId); aimAt(e);
    });
    c.addEventListener("pointermove", (e) => { pick.pointer = nmAt(e); if ((e.buttons & 1) && !pick.phase && !pick.busy) aimAt(e); });
    $("stroke").onclick = () => armStroke(!pick.phase);
    c.addEventListener("wheel", (e) => { e.preventDefault(); setLoad(e.deltaY < 0 ? 0.5 : -0.5); }, { passive: false });
    $("engage").onclick = () => engage(!state.hand.engaged);
    $("scan").onclick = () => { if (lastMeta) askScan(lastMeta.tip_nm); };
    c.addEventListener("contextmenu", (e) => { e.preventDefault(); const p = nmAt(e); if (p) askScan(particleAt(p) || p); });
    requestAnimationFrame(padLoop);
    document.addEventListener("keydown", (e) => {
      if (e.key === " ") { e.preventDefault(); engage(!state.hand.engaged); }
      else if (e.key === "ArrowUp") setLoad(0.5);
      else if (e.key === "ArrowDown") setLoad(-0.5);
      else if (e.key === "s" || e.key === "S") { if (lastMeta) askScan(lastMeta.tip_nm); }
      else if (e.key === "p" || e.key === "P") armStroke(!pick.phase);
      else if (e.key === "Escape") armStroke(false);
    });
  }
  // A planner stroke (docs/view.md): the stroke button (or P) arms it, a
  // click on a particle (its disc in the card's model, as the frame shows
  // it) picks it, a click elsewhere then is its target; the operator's
  // planner pushes it there, the hand yielding meanwhile, and the
  // operator's heartbeat says how it went (pushNews). window.afmView.stroke
  // holds the page's side: {phase, id, target_nm, news: [...]}.
  const pick = state.stroke = { phase: null, id: null, target_nm: null, busy: false, pointer: null, news: [] };
  function armStroke(on) {
    if (on && pick.busy) return;
    pick.phase = on ? "particle" : null;
    pick.id = null;
    pick.target_nm = null;
    showStroke(on ? "click the particle to push" : "");
  }
  function pickAt(e) {
    const p = nmAt(e);
    if (!p) return;
    if (pick.phase === "particle") {
      const hit = particleAt(p);
      if (!hit) { showStroke("no particle there: click one (Esc cancels)"); return; }
      pick.id = hit[2];
      pick.phase = "target";
      showStroke(`particle ${pick.id}: click its target`);
      return;
    }
    pick.target_nm = p;
    pick.phase = null;
    pick.busy = true;
    ws.send(JSON.stringify({ type: "push", id: pick.id, x_nm: p[0], y_nm: p[1] }));
    showStroke(`particle ${pick.id} to (${p[0].toFixed(0)}, ${p[1].toFixed(0)}) nm: asked`);
  }
  function pushNews(m) {
    pick.news.push(m);
    const to = `particle ${m.id} to (${m.x_nm.toFixed(0)}, ${m.y_nm.toFixed(0)}) nm`;
    if (m.phase === "start") { pick.busy = true; pick.since = m.sim_s; showStroke(`${to}: the planner pushes it (from ${m.sim_s.toFixed(2)} s)`); return; }
    if (m.phase === "progress") {
      showStroke(`${to}: the planner pushes it: ${m.pushes} push(es), ${m.scans} scan(s) so far, ` +
                 `${(m.sim_s - (pick.since || 0)).toFixed(1)} s`);
      return;
    }
    pick.busy = false;
    pick.id = null;
    pick.target_nm = null;
    if (state.hand) { state.hand.engaged = false; state.hand.target_nm = null; showHand(); }   // lifted where the stroke left it
    showStroke(`${to}: ` + (m.placed ? `placed, ${m.error_nm.toFixed(1)} nm off` : `not placed (${m.why || "?"})`) +
               ` after ${m.pushes} push(es), ${m.scans} scan(s), at ${m.sim_s.toFixed(2)} s`);
  }
  function showStroke(text) {
    $("strokemsg").textContent = text;
    $("stroke").className = pick.phase || pick.busy ? "on" : "";
  }
  // A gamepad (the browser's Gamepad API, polled every animation frame): the
  // left stick moves the hand's target at up to PAD_NM_PER_S, the right and
  // left triggers raise and lower the load at PAD_LOAD_NN_PER_S, button 0
  // (A) engages and lifts; a pad with a vibration actuator rumbles with the
  // force the hand feels, full at PAD_RUMBLE_FULL_N. padStep and rumble are
  // pure (window.afmView holds them for the test, which feeds a fake pad).
  const PAD_NM_PER_S = 800, PAD_DEAD = 0.12, PAD_LOAD_NN_PER_S = 5, PAD_RUMBLE_FULL_N = 0.2;
  function padStep(h, pad, dt, tip) {
    const out = { target_nm: h.target_nm ? h.target_nm.slice() : (tip ? tip.slice() : null), load_nN: h.load_nN,
                  engaged: h.engaged, a: !!(pad.buttons[0] && pad.buttons[0].pressed), moved: false };
    const axis = (v) => (Math.abs(v || 0) > PAD_DEAD ? v : 0);
    const ax = axis(pad.axes[0]), ay = axis(pad.axes[1]);
    if (out.target_nm && (ax || ay)) {   // stick up (axis 1 negative) is +y, as on the image
      out.target_nm[0] += ax * PAD_NM_PER_S * dt;
      out.target_nm[1] -= ay * PAD_NM_PER_S * dt;
      out.moved = true;
    }
    const up = (pad.buttons[7] && pad.buttons[7].value) || 0, down = (pad.buttons[6] && pad.buttons[6].value) || 0;
    out.load_nN = Math.max(0.5, Math.min(100, h.load_nN + (up - down) * PAD_LOAD_NN_PER_S * dt));
    if (out.a && !h.padA) out.engaged = !h.engaged;   // on the press, not while held
    return out;
  }
  function rumble(handN) { return Math.min(1, Math.hypot(handN[0], handN[1]) / PAD_RUMBLE_FULL_N); }
  state.padStep = padStep;
  state.rumble = rumble;
  function firstPad() {
    const pads = navigator.getGamepads ? navigator.getGamepads() : [];
    for (const p of pads || []) if (p && p.connected !== false) return p;
    return null;
  }
  function padLoop(now) {
    const h = state.hand, pad = firstPad();
    if (pad && h) {
      const dt = h.padT ? Math.min(0.1, (now - h.padT) / 1000) : 0;
      const n = padStep(h, pad, dt, lastMeta ? lastMeta.tip_nm : null);
      const changed = n.moved || n.load_nN !== h.load_nN || n.engaged !== h.engaged;
      h.target_nm = n.target_nm; h.load_nN = n.load_nN; h.engaged = n.engaged; h.padA = n.a;
      state.pad = pad.id || "gamepad";
      if (changed) { showHand(); sendHand(); }
    }
    if (h) h.padT = now;
    requestAnimationFrame(padLoop);
  }
  // The pointer's place in the field (nm), or null before a frame.
  function nmAt(e) {
    if (!lastMeta || !lastMeta.field_nm) return null;
    const r = $("image").getBoundingClientRect(), k = $("image").width / lastMeta.width;
    const [x0, y0, side] = lastMeta.field_nm, pitch = side / lastMeta.width;
    const px = (e.clientX - r.left) * $("image").width / r.width, py = (e.clientY - r.top) * $("image").height / r.height;
    return [x0 + px / k * pitch, y0 + (lastMeta.height - py / k) * pitch];
  }
  function aimAt(e) {
    const p = nmAt(e);
    if (!p) return;
    state.hand.target_nm = p;
    sendHand();
  }
  // The card's particle (as the frame shows it) whose disc holds p, or null.
  function particleAt(p) {
    for (const [id, x, y, r] of (lastMeta && lastMeta.particles) || [])   // [id, x_nm, y_nm, radius_nm]
      if (Math.hypot(x - p[0], y - p[1]) <= r) return [x, y, id];
    return null;
  }
  // A local scan around c (nm), SCAN_FRACTION of the field on a side: the
  // operator asks for it and the renderer pastes it into the image.
  const SCAN_FRACTION = 0.25;
  function askScan(c) {
    if (!lastMeta || !lastMeta.field_nm || ws.readyState !== 1) return;
    state.hand.scans = (state.hand.scans || 0) + 1;
    ws.send(JSON.stringify({ type: "scan", x_nm: c[0], y_nm: c[1], size_nm: lastMeta.field_nm[2] * SCAN_FRACTION }));
  }
  function setLoad(d) { if (pick.busy) return; state.hand.load_nN = Math.max(0.5, Math.min(100, state.hand.load_nN + d)); showHand(); sendHand(); }
  function engage(on) { if (pick.busy) return; state.hand.engaged = on; showHand(); sendHand(); }
  function showHand() {
    $("load").textContent = state.hand.load_nN.toFixed(1);
    $("engage").textContent = state.hand.engaged ? "lift" : "engage";
    $("engage").className = state.hand.engaged ? "on" : "";
  }
  function sendHand() {
    const h = state.hand;
    if (!h.target_nm && lastMeta) h.target_nm = [lastMeta.tip_nm[0], lastMeta.tip_nm[1]];
    if (!h.target_nm || ws.readyState !== 1 || pick.busy) return;   // a stroke drives the tip: nothing sent
    const wait = h.last + HAND_SEND_MS - performance.now();
    if (wait > 0) { if (!h.timer) h.timer = setTimeout(() => { h.timer = null; sendHand(); }, wait); return; }
    h.last = performance.now();
    h.sent += 1;
    ws.send(JSON.stringify({ type: "hand", x_nm: h.target_nm[0], y_nm: h.target_nm[1], load_nN: h.load_nN, engaged: h.engaged }));
  }

  function hello(m) {
    state.mode = m.mode;
    if (m.hand) enableHand(m.hand);
    state.flags = m.flags;
    $("mode").textContent = m.mode === "live" ? "live" : "recorded: " + m.run_dir;
    $("flags").innerHTML = "";
    for (const name of Object.keys(m.flags)) {
      const s = document.createElement("span");
      s.textContent = name;
      s.id = "flag-" + name;
      $("flags").appendChild(s);
    }
    if (m.mode === "recorded") {
      for (const k of Object.keys(series)) series[k] = m.chart[k];
      state.chartSamples = series.t.length;
      state.framesTotal = m.frames_total;
      $("scrub").hidden = false;
      $("pos").max = String(m.frames_total - 1);
      $("pos").oninput = () => seek(Number($("pos").value));
      $("play").onclick = () => { playing = !playing; $("play").textContent = playing ? "pause" : "play"; if (playing) step(); };
      seek(0);
    }
  }

  function seek(pos) { ws.send(JSON.stringify({ type: "seek", position: pos })); }
  function step() {
    if (!playing || !lastMeta) return;
    const pos = lastMeta.position + 1;
    if (pos >= state.framesTotal) { playing = false; $("play").textContent = "play"; return; }
    $("pos").value = String(pos);
    seek(pos);
  }

  function onImage(buf) {
    if (!meta) return;
    const m = meta;
    m.t_page_ms = performance.timeOrigin + performance.now();
    meta = null;
    if (m.samples) addSamples(m.samples);
    state.skippedRenderer += m.skipped;
    state.skippedServer = m.skipped_server || 0;
    if (decoding) { if (next) state.skippedPage += 1; next = [m, buf]; return; }
    show(m, buf);
  }

  function show(m, buf) {
    decoding = true;
    createImageBitmap(new Blob([buf], { type: m.image })).then((bmp) => {
      draw(m, bmp);
      bmp.close();
    }).catch(() => {}).finally(() => {
      decoding = false;
      if (next) { const [nm, nb] = next; next = null; show(nm, nb); }
      else if (playing) setTimeout(step, 40);
    });
  }

  function addSamples(s) {
    for (const k of Object.keys(series)) for (const v of s[k] || []) series[k].push(v);
    const t0 = series.t.length ? series.t[series.t.length - 1] - 2 * CHART_S : 0;
    let cut = 0;
    while (cut < series.t.length && series.t[cut] < t0) cut += 1;
    if (cut) for (const k of Object.keys(series)) series[k].splice(0, cut);
    state.chartSamples += (s.t || []).length;
  }

  function draw(m, bmp) {
    const c = img.canvas, k = c.width / m.width;
    img.drawImage(bmp, 0, 0, c.width, c.height);
    overlay(m, k);
    drawGlyph(m.force_nN);
    drawFlags(m.flags);
    drawChart(m.t_s);
    state.particles = m.particles;
    state.meta = { field_nm: m.field_nm, width: m.width, height: m.height };
    state.framesShown += 1;
    if (state.painted.length < 100000) {
      const drawn = performance.timeOrigin + performance.now();
      requestAnimationFrame(() => state.painted.push([m.seq, performance.timeOrigin + performance.now(), m.t_rx_ms, m.t_tx_ms,
                                                      m.t_page_ms, drawn]));
    }
    state.lastIndex = m.index;
    state.framesTotal = m.frames_total;
    state.t = m.t_s;
    lastMeta = m;
    if (state.mode === "recorded") $("pos").value = String(m.position);
    $("bar").style.width = (100 * (m.index + 1) / Math.max(1, m.frames_total)).toFixed(1) + "%";
    $("stats").textContent =
      `frame ${m.index + 1} / ${m.frames_total}   t ${m.t_s.toFixed(3)} s   block ${m.seq}\n` +
      `F (nN)  x ${m.force_nN[0].toFixed(2)}  y ${m.force_nN[1].toFixed(2)}  z ${m.force_nN[2].toFixed(2)}   ` +
      `hand ${Math.hypot(m.hand_N[0], m.hand_N[1]).toFixed(3)} N\n` +
      `frames shown ${state.framesShown}; skipped: by the renderer ${state.skippedRenderer}, ` +
      `by the server ${state.skippedServer}, by this page ${state.skippedPage}`;
  }

  // nm in the field -> canvas px (row 0 at the field's top edge).
  function toPx(m, k, x, y) {
    const [x0, y0, side] = m.field_nm, pitch = side / m.width;
    return [(x - x0) / pitch * k, (m.height - (y - y0) / pitch) * k];
  }

  function overlay(m, k) {
    if (!m.field_nm) return;
    // the objects' ids, axes and the force glyph are in the frame itself (the renderer's overlay)
    const [tx, ty] = toPx(m, k, m.tip_nm[0], m.tip_nm[1]);
    if (!isFinite(tx)) return;
    img.strokeStyle = "#0ff";
    img.lineWidth = 1.5;
    img.beginPath(); img.arc(tx, ty, 7, 0, 2 * Math.PI); img.stroke();
    arrow(img, tx, ty, tx + m.force_nN[0] * 12, ty - m.force_nN[1] * 12, "#0ff");
    if (state.hand && state.hand.target_nm) {   // the target, and the stylus's lag behind it
      const [gx, gy] = toPx(m, k, state.hand.target_nm[0], state.hand.target_nm[1]);
      img.strokeStyle = "#f6c"; img.lineWidth = 1;
      img.beginPath(); img.moveTo(gx - 8, gy); img.lineTo(gx + 8, gy); img.moveTo(gx, gy - 8); img.lineTo(gx, gy + 8);
      img.setLineDash([3, 3]); img.moveTo(tx, ty); img.lineTo(gx, gy); img.stroke(); img.setLineDash([]);
    }
    if (state.hand && (pick.id !== null)) {   // the stroke asked for: its particle ringed, a line to its target (or the pointer)
      const q = (m.particles || []).find((x) => x[0] === pick.id);
      if (q) {
        const [qx, qy] = toPx(m, k, q[1], q[2]), to = pick.target_nm || pick.pointer;
        img.strokeStyle = "#7f7"; img.lineWidth = 2;
        img.beginPath(); img.arc(qx, qy, q[3] / (m.field_nm[2] / m.width) * k + 4, 0, 2 * Math.PI); img.stroke();
        if (to) {
          const [ux, uy] = toPx(m, k, to[0], to[1]);
          img.setLineDash([6, 4]); img.beginPath(); img.moveTo(qx, qy); img.lineTo(ux, uy); img.stroke(); img.setLineDash([]);
          img.beginPath(); img.arc(ux, uy, 5, 0, 2 * Math.PI); img.stroke();
        }
      }
    }
    if (state.hand) {
      const hn = Math.hypot(m.hand_N[0], m.hand_N[1]);
      $("handN").textContent = hn.toFixed(3) + " N";
      const pad = firstPad();
      if (pad && pad.vibrationActuator && pad.vibrationActuator.playEffect) {
        const g = rumble(m.hand_N);
        pad.vibrationActuator.playEffect("dual-rumble", { duration: 80, strongMagnitude: g, weakMagnitude: g }).catch(() => {});
      }
      $("handfill").style.width = Math.min(100, hn / 0.1 * 100).toFixed(0) + "%";
    }
  }

  function arrow(ctx, x0, y0, x1, y1, colour) {
    const a = Math.atan2(y1 - y0, x1 - x0), h = Math.min(8, Math.hypot(x1 - x0, y1 - y0) / 2);
    ctx.strokeStyle = colour;
    ctx.beginPath(); ctx.moveTo(x0, y0); ctx.lineTo(x1, y1);
    ctx.lineTo(x1 - h * Math.cos(a - 0.4), y1 - h * Math.sin(a - 0.4));
    ctx.moveTo(x1, y1); ctx.lineTo(x1 - h * Math.cos(a + 0.4), y1 - h * Math.sin(a + 0.4));
    ctx.stroke();
  }

  // The force as a 3-D glyph (an oblique view of x, y, z) and F_z as a bar.
  function drawGlyph(f) {
    const g = glyph, W = g.canvas.width, H = g.canvas.height, ox = 95, oy = 120;
    g.clearRect(0, 0, W, H);
    const scale = 60 / Math.max(2, Math.hypot(f[0], f[1], f[2]));
    const proj = (x, y, z) => [ox + (x - 0.5 * y) * scale, oy - (z + 0.35 * y) * scale];
    g.lineWidth = 1;
    for (const [v, name] of [[[1, 0, 0], "x"], [[0, 1, 0], "y"], [[0, 0, 1], "z"]]) {
      const [px, py] = proj(v[0] * 1.2 / scale * 60, v[1] * 1.2 / scale * 60, v[2] * 1.2 / scale * 60);
      arrow(g, ox, oy, px, py, "#555");
      g.fillStyle = "#888"; g.fillText(name, px + 3, py);
    }
    g.lineWidth = 2.5;
    const [fx, fy] = proj(f[0], f[1], f[2]);
    arrow(g, ox, oy, fx, fy, "#fc3");
    g.lineWidth = 1;
    const bx = 215, bh = 80, fz = Math.max(-1, Math.min(1, f[2] / 20));
    g.strokeStyle = "#666"; g.strokeRect(bx, oy - bh, 18, 2 * bh);
    g.fillStyle = f[2] >= 0 ? "#4a8" : "#e55";
    g.fillRect(bx + 1, fz >= 0 ? oy - fz * bh : oy, 16, Math.abs(fz) * bh);
    g.fillStyle = "#ddd";
    g.fillText("F_z " + f[2].toFixed(1) + " nN", bx - 20, 14);
    g.fillText("|F| " + Math.hypot(f[0], f[1], f[2]).toFixed(2) + " nN", 4, 14);
  }

  function drawFlags(bits) {
    for (const [name, bit] of Object.entries(state.flags)) {
      const el = $("flag-" + name);
      if (el) el.className = bits & bit ? "on" : "";
    }
  }

  // The card's force (F_z, |F_lateral|, nN, left axis) and the hand's force
  // (|F|, N, right axis) over the CHART_S seconds up to t.
  function drawChart(t) {
    const c = chart, W = c.canvas.width, H = c.canvas.height, L = 44, R = 50, T = 22, B = 22;
    c.clearRect(0, 0, W, H);
    // the window's edges: [0, CHART_S] until t reaches CHART_S, then
    // [t - CHART_S, t]; each edge is labelled with its own time
    const hi = Math.max(t, CHART_S), lo = hi - CHART_S;
    state.chartEdges = [lo, hi];
    let i0 = 0, i1 = series.t.length;
    while (i0 < i1 && series.t[i0] < lo) i0 += 1;
    while (i1 > i0 && series.t[i1 - 1] > t) i1 -= 1;
    const pick = (f) => { const out = []; for (let i = i0; i < i1; i += 1) out.push(f(i)); return out; };
    const ts = pick((i) => series.t[i]);
    const card = [pick((i) => series.fz[i]), pick((i) => Math.hypot(series.fx[i], series.fy[i]))];
    const hand = pick((i) => Math.hypot(series.hx[i], series.hy[i]));
    state.chartT = [ts.length ? ts[0] : null, ts.length ? ts[ts.length - 1] : null, ts.length];
    const range = (arrs) => { let a = Infinity, b = -Infinity; for (const v of arrs.flat()) { a = Math.min(a, v); b = Math.max(b, v); }
      return isFinite(a) ? (b - a < 1e-9 ? [a - 1, b + 1] : [a, b]) : [0, 1]; };
    const [ylo, yhi] = range(card), [hlo, hhi] = range([hand, [0]]);
    const X = (tt) => L + (tt - lo) / CHART_S * (W - L - R);
    c.strokeStyle = "#444"; c.strokeRect(L, T, W - L - R, H - T - B);
    c.fillStyle = "#aaa"; c.font = "11px sans-serif";
    c.fillText(yhi.toFixed(1), 2, T + 9); c.fillText(ylo.toFixed(1), 2, H - B);
    c.fillText(hhi.toFixed(3), W - R + 3, T + 9); c.fillText("N", W - R + 3, T + 22);
    c.fillText("nN", 2, T + 22); state.chartLabels = [lo.toFixed(1) + " s", hi.toFixed(1) + " s"];
    c.fillText(state.chartLabels[0], L, H - 6);
    c.fillText(state.chartLabels[1], W - R - 30, H - 6);
    const line = (ys, a, b, colour) => {
      c.strokeStyle = colour; c.beginPath();
      ys.forEach((v, i) => { const y = T + (1 - (v - a) / (b - a)) * (H - T - B);
        if (i) c.lineTo(X(ts[i]), y); else c.moveTo(X(ts[i]), y); });
      c.stroke();
    };
    line(card[0], ylo, yhi, "#4a8"); line(card[1], ylo, yhi, "#0ff"); line(hand, hlo, hhi, "#fc3");
    c.fillStyle = "#4a8"; c.fillText("card F_z", L + 6, 14);
    c.fillStyle = "#0ff"; c.fillText("card |F_lat|", L + 66, 14);
    c.fillStyle = "#fc3"; c.fillText("hand |F|", L + 146, 14);
  }

  function procs(p) {
    // a process that steps no simulated clock (the launcher, the operator:
    // their heartbeats carry sim_utime 0) shows its state without a time
    $("procs").textContent = Object.entries(p).map(([n, s]) =>
      `${n.padEnd(9)} ${s.state.padEnd(9)} ${s.clocked ? s.sim_s.toFixed(2) + " s" : "(no sim clock)"}`).join("\n");
    state.procs = p;
  }

  function ended(m) {
    state.ended = m;
    $("status").textContent = `run ended: ${m.status || "exit " + m.exit_code}` ;
  }
})();
