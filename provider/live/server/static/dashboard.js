// shlight dashboard: live SH9 lighting from this server's WebSocket (see provider/live/server/service.py).
// Vanilla JS, no build step, no inline code (the page is served with a strict CSP).
"use strict";
(function () {
  const NAMES = ["L00", "L1-1", "L10", "L11", "L2-2", "L2-1", "L20", "L21", "L22"];
  const ALBEDO = 0.8;
  const params = new URLSearchParams(location.search);
  const token = params.get("token");
  const $ = (id) => document.getElementById(id);

  const state = {
    ws: null, retry: 0.5, retryTimer: null, connected: false,
    probes: [], selected: params.get("probe") || null,
    latest: {},          // probe -> {msg, at (performance.now() on arrival)}
    arrivals: {},        // probe -> recent arrival times, for messages/s
    staleAfter: 2.0, keepalive: 1.0,
    pings: {}, pingId: 0, rtt: null,
    drawPending: false, clamped: null,
  };

  // ---- connection ------------------------------------------------------------------------
  function wsUrl() {
    const url = new URL("/", location.href);
    url.protocol = location.protocol === "https:" ? "wss:" : "ws:";
    if (token) url.searchParams.set("token", token);
    return url.href;
  }

  function setConn(kind, text) {
    const el = $("conn");
    el.dataset.state = kind;
    el.textContent = text;
  }

  function connect() {
    clearTimeout(state.retryTimer);
    setConn("connecting", "connecting");
    let ws;
    try {
      ws = new WebSocket(wsUrl());
    } catch (err) {
      scheduleReconnect();
      return;
    }
    state.ws = ws;
    ws.binaryType = "arraybuffer";     // reflection cubes (dashboard-environment.js)
    ws.onmessage = (ev) => {
      if (ev.data instanceof ArrayBuffer) {
        if (window.shlightEnvironment) window.shlightEnvironment.cube(ev.data);
        return;
      }
      let msg;
      try { msg = JSON.parse(ev.data); } catch (err) { return; }
      if (msg && typeof msg === "object") onMessage(msg);
    };
    ws.onclose = (ev) => {
      if (state.ws !== ws) return;
      state.ws = null;
      state.connected = false;
      scheduleReconnect(ev.code);
    };
  }

  function scheduleReconnect(code) {
    const wait = state.retry;
    state.retry = Math.min(state.retry * 2, 10);
    const why = code && code !== 1006 ? ` (close ${code})` : "";
    setConn("down", `disconnected${why}, retrying in ${wait} s`);
    state.retryTimer = setTimeout(connect, wait * 1000);
  }

  function send(obj) {
    if (state.ws && state.ws.readyState === WebSocket.OPEN) state.ws.send(JSON.stringify(obj));
  }

  function onMessage(msg) {
    if (msg.type === "hello") {
      state.connected = true;
      state.retry = 0.5;
      state.staleAfter = +msg.stale_after_s || 2.0;
      state.keepalive = +msg.keepalive_s || 1.0;
      setProbes(Array.isArray(msg.probes) ? msg.probes.map(String) : []);
      $("provider").textContent = `${msg.provider || ""} · ${msg.frame || ""}`;
      setConn("live", "live");
      refreshMqtt();
      // Reflection cubes (shlight serve --environment): asked for, as any client must.
      state.environment = Array.isArray(msg.environment) && msg.environment.length > 0;
      if (state.environment && window.shlightEnvironment) send({ type: "subscribe", environment: true });
    } else if (msg.type === "sh9") {
      if (!Array.isArray(msg.matrices) || msg.matrices.length !== 48 ||
          !Array.isArray(msg.coefficients) || msg.coefficients.length !== 27) return;
      const probe = String(msg.probe);
      const now = performance.now();
      state.latest[probe] = { msg, at: now };
      const times = (state.arrivals[probe] = state.arrivals[probe] || []);
      times.push(now);
      while (times.length && now - times[0] > 5000) times.shift();
      if (!state.probes.includes(probe)) setProbes(state.probes.concat([probe]));
      if (probe === state.selected) {
        requestDraw();
        showNumbers();
        if (!$("thumb").dataset.loaded) refreshThumbnail();
      }
    } else if (msg.type === "environment" && window.shlightEnvironment) {
      // its KTX2 bytes are the next (binary) frame; only the selected probe's are shown
      window.shlightEnvironment.announce(String(msg.probe) === state.selected ? msg : null);
    } else if (msg.type === "pong") {
      const sent = state.pings[msg.id];
      if (sent !== undefined) {
        state.rtt = performance.now() - sent;
        delete state.pings[msg.id];
      }
    }
  }

  function setProbes(list) {
    state.probes = list;
    if (!state.selected || !list.includes(state.selected)) state.selected = list[0] || null;
    const select = $("probe");
    select.replaceChildren(...list.map((name) => {
      const opt = document.createElement("option");
      opt.value = opt.textContent = name;
      return opt;
    }));
    if (state.selected) select.value = state.selected;
    $("probe-picker").hidden = list.length < 2;
  }

  // ---- the lit sphere ----------------------------------------------------------------------
  const SRGB = new Uint8ClampedArray(4096);
  for (let i = 0; i < 4096; i++) {
    const x = i / 4095;
    const s = x <= 0.0031308 ? 12.92 * x : 1.055 * Math.pow(x, 1 / 2.4) - 0.055;
    SRGB[i] = Math.round(s * 255);
  }

  function requestDraw() {
    if (state.drawPending) return;
    state.drawPending = true;
    requestAnimationFrame(() => { state.drawPending = false; drawSphere(); });
  }

  function drawSphere() {
    const entry = state.latest[state.selected];
    const canvas = $("sphere");
    const ctx = canvas.getContext("2d");
    const w = canvas.width, h = canvas.height;
    const img = ctx.createImageData(w, h);
    const px = img.data;
    if (!entry) { ctx.putImageData(img, 0, 0); return; }
    const M = entry.msg.matrices;
    const n = w * h;
    const rad = new Float32Array(n * 3);
    const inside = new Uint8Array(n);
    let lumSum = 0, count = 0, clamped = 0;
    for (let j = 0; j < h; j++) {
      const y = 1 - (2 * (j + 0.5)) / h;
      for (let i = 0; i < w; i++) {
        const x = (2 * (i + 0.5)) / w - 1;
        const r2 = x * x + y * y;
        if (r2 > 1) continue;
        const z = Math.sqrt(1 - r2);
        const k = j * w + i;
        let neg = false;
        for (let c = 0; c < 3; c++) {
          // E = ñᵀ M ñ with ñ = (x, y, z, 1); M row-major, one 4×4 per channel.
          const o = 16 * c;
          const r0 = M[o] * x + M[o + 1] * y + M[o + 2] * z + M[o + 3];
          const r1 = M[o + 4] * x + M[o + 5] * y + M[o + 6] * z + M[o + 7];
          const r2 = M[o + 8] * x + M[o + 9] * y + M[o + 10] * z + M[o + 11];
          const r3 = M[o + 12] * x + M[o + 13] * y + M[o + 14] * z + M[o + 15];
          let e = x * r0 + y * r1 + z * r2 + r3;
          if (!(e > 0)) { neg = neg || e < 0; e = 0; }
          rad[3 * k + c] = (ALBEDO * e) / Math.PI;
        }
        if (neg) clamped++;
        inside[k] = 1;
        lumSum += 0.2126 * rad[3 * k] + 0.7152 * rad[3 * k + 1] + 0.0722 * rad[3 * k + 2];
        count++;
      }
    }
    state.clamped = count ? clamped / count : 0;
    // Exposure: auto puts the mean luminance at 0.5 before the 1 - e^(-x) curve (as the
    // thumbnail does); the EV slider adds stops on top.
    const ev = +$("ev").value;
    let exposure = Math.pow(2, ev);
    if ($("auto").checked) exposure *= lumSum > 0 && count ? 0.5 / (lumSum / count) : 1;
    if (window.shlightEnvironment) window.shlightEnvironment.lighting(M, exposure);
    for (let k = 0; k < n; k++) {
      const p = 4 * k;
      if (!inside[k]) { px[p + 3] = 0; continue; }
      for (let c = 0; c < 3; c++) {
        const t = 1 - Math.exp(-exposure * rad[3 * k + c]);
        px[p + c] = SRGB[Math.min(4095, Math.max(0, Math.round(t * 4095)))];
      }
      px[p + 3] = 255;
    }
    ctx.putImageData(img, 0, 0);
  }

  // ---- numbers and bars --------------------------------------------------------------------
  const fmt = (v, digits, unit) =>
    typeof v === "number" && isFinite(v) ? `${v.toFixed(digits)}${unit || ""}` : "–";

  function buildBars() {
    const root = $("bars");
    for (let i = 0; i < 9; i++) {
      const row = document.createElement("div");
      row.className = "bar-row";
      const label = document.createElement("span");
      label.className = "bar-label";
      label.textContent = NAMES[i];
      row.appendChild(label);
      for (let c = 0; c < 3; c++) {
        const track = document.createElement("span");
        track.className = "bar-track";
        const fill = document.createElement("span");
        fill.className = "bar-fill " + "rgb"[c];
        fill.id = `bar-${3 * i + c}`;
        track.appendChild(fill);
        row.appendChild(track);
      }
      root.appendChild(row);
    }
  }

  function showBars(coefs) {
    let scale = 0;
    for (const v of coefs) scale = Math.max(scale, Math.abs(v));
    for (let k = 0; k < 27; k++) {
      const v = +coefs[k];
      const f = scale > 0 ? Math.min(1, Math.abs(v) / scale) : 0;
      const el = $(`bar-${k}`);
      el.style.width = `${50 * f}%`;
      el.style.left = v >= 0 ? "50%" : `${50 - 50 * f}%`;
      el.parentElement.title = `${NAMES[Math.floor(k / 3)]}.${"rgb"[k % 3]} = ${v.toPrecision(5)}`;
    }
  }

  function showNumbers() {
    const entry = state.latest[state.selected];
    if (!entry) return;
    const m = entry.msg;
    const age = (+m.age_s || 0) + (performance.now() - entry.at) / 1000;
    const times = state.arrivals[state.selected] || [];
    const span = times.length > 1 ? (times[times.length - 1] - times[0]) / 1000 : 0;
    $("s-probe").textContent = state.selected;
    $("s-source").textContent = m.source || "–";
    $("s-fps").textContent = fmt(m.fps, 1);
    $("s-rate").textContent = span > 0 ? ((times.length - 1) / span).toFixed(1) : "–";
    $("s-compute").textContent = fmt(m.compute_ms, 2, " ms");
    $("s-latency").textContent = typeof m.latency_ms === "number"
      ? fmt(m.latency_ms, 1, " ms") : fmt(1000 * (Date.now() / 1000 - m.time), 0, " ms (age)");
    $("s-age").textContent = fmt(age, 1, " s");
    $("s-rtt").textContent = fmt(state.rtt, 1, " ms");
    $("s-seq").textContent = String(m.seq);
    // What the numbers are (contract §9): radiance per second of exposure when it is known.
    $("s-radiometry").textContent = (m.radiometry || "–") +
      (typeof m.exposure_s === "number" ? ` · ${fmt(1000 * m.exposure_s, 2, " ms")}` : "") +
      (Array.isArray(m.exposures_s) && m.exposures_s.length ? ` · ${m.exposures_s.length} shots` : "");
    $("s-clipped").textContent = fmt(100 * m.clipped_fraction, 1, " %") +
      (m.clipped_light_fraction > 0 ? ` (${fmt(100 * m.clipped_light_fraction, 1, " %")} of the light)` : "");
    // Photometry (contract "Photometric units"): lux and EV100 when absolute, CCT always,
    // and what a lux meter closed.
    $("s-photometry").textContent = [
      typeof m.illuminance_lux === "number" ? `${fmt(m.illuminance_lux, 0, " lx")} up` : m.coefficient_units || "–",
      typeof m.ev100 === "number" ? `EV100 ${fmt(m.ev100, 1)}` : "",
      typeof m.cct_k === "number" ? `${fmt(m.cct_k, 0, " K")} (Duv ${fmt(m.duv, 4)})` : "",
      m.meter_closed_lux > 0 ? `meter closed ${fmt(m.meter_closed_lux, 0, " lx")}` : "",
    ].filter(Boolean).join(" · ");
    $("s-error").textContent = fmt(100 * m.error_estimate, 1, " %");
    // Lights (contract §10): how many, and the error they leave against SH9 alone.
    $("s-lights").textContent = !(m.lights > 0) ? (typeof m.light_error === "number" ? "none needed" : "off")
      : `${m.lights} · error ${fmt(100 * m.light_error, 1, " %")} (SH9 alone ${fmt(100 * m.sh9_error, 1, " %")})`;
    $("s-clamped").textContent = fmt(state.clamped === null ? NaN : 100 * state.clamped, 1, " %");
    showBars(m.coefficients);
    // Stale: the server says so, or nothing arrived for much longer than its keep-alive.
    const silent = performance.now() - entry.at > 1000 * (state.keepalive * 2 + state.staleAfter);
    const stale = m.stale === true || (state.connected && silent);
    const badge = $("stale");
    badge.hidden = !stale;
    badge.textContent = stale ? `STALE · last frame ${age.toFixed(1)} s ago` : "";
    document.body.classList.toggle("is-stale", stale);
    // Connected but stale is not "live": no green badge beside the red one.
    if (state.connected) setConn(stale ? "connected" : "live", stale ? "connected" : "live");
  }

  // ---- panorama thumbnail ------------------------------------------------------------------
  let thumbBusy = false, thumbUrl = null;
  async function refreshThumbnail() {
    const probe = state.selected;
    if (thumbBusy || !probe || !state.latest[probe] || document.hidden) return;
    thumbBusy = true;
    try {
      const url = new URL("/thumbnail.jpg", location.href);
      url.searchParams.set("probe", probe);
      if (token) url.searchParams.set("token", token);
      const resp = await fetch(url, { cache: "no-store" });
      if (resp.ok && probe === state.selected) {
        const blob = await resp.blob();
        const img = $("thumb");
        if (thumbUrl) URL.revokeObjectURL(thumbUrl);
        thumbUrl = URL.createObjectURL(blob);
        img.src = thumbUrl;
        img.hidden = false;
        img.dataset.loaded = "1";
        $("thumb-none").hidden = true;
      }
    } catch (err) {
      // the server is away; the WebSocket shows it and reconnects
    } finally {
      thumbBusy = false;
    }
  }

  // ---- MQTT publishing (shlight serve --mqtt): its state from /healthz ----------------------
  async function refreshMqtt() {
    if (document.hidden) return;
    try {
      const resp = await fetch(new URL("/healthz", location.href), { cache: "no-store" });
      const mqtt = resp.ok ? (await resp.json()).mqtt : null;
      $("mqtt-row").hidden = !mqtt;
      if (!mqtt) return;
      const el = $("s-mqtt");
      el.dataset.state = mqtt.state;
      el.textContent = `${mqtt.state} · ${mqtt.broker} · ${mqtt.published} sent` +
        (mqtt.state !== "connected" && mqtt.error ? ` · ${mqtt.error}` : "");
    } catch (err) {
      // the server is away; the WebSocket shows it
    }
  }

  // ---- wiring ------------------------------------------------------------------------------
  function init() {
    buildBars();
    $("probe").addEventListener("change", (ev) => {
      state.selected = ev.target.value;
      delete $("thumb").dataset.loaded;
      if (state.environment && window.shlightEnvironment) {
        window.shlightEnvironment.forget();
        send({ type: "subscribe", environment: true });   // the newest cubes again
      }
      requestDraw();
      showNumbers();
      refreshThumbnail();
    });
    $("ev").addEventListener("input", () => { $("ev-out").textContent = $("ev").value; requestDraw(); });
    $("auto").addEventListener("change", requestDraw);
    setInterval(() => { if (state.connected) showNumbers(); }, 250);
    setInterval(() => { if (state.connected) refreshThumbnail(); }, 1000);
    setInterval(() => { if (state.connected) refreshMqtt(); }, 2000);
    setInterval(() => {
      if (!state.connected) return;
      const id = ++state.pingId;
      state.pings = { [id]: performance.now() };
      send({ type: "ping", id });
    }, 2000);
    connect();
  }

  if (document.readyState === "loading") document.addEventListener("DOMContentLoaded", init);
  else init();
})();
