// hazmap live view: the viewer page connected to `hazmap live` over its WebSocket (/ws): new map
// voxels (moved with their segments after loop corrections), the trajectory (redrawn whole after
// them), the robot's pose, the hazards with their values and the status line. On every (re)connection the server sends its snapshot
// first, so the page starts again from it; a closed connection is retried every second.
// `?token=T` in the page's address is passed on; `?live=HOST:PORT` points a page opened from a
// file at a server. window.hazmapLive exposes the state for tests and scripts.
(function () {
  'use strict';
  const v = window.hazmapViewer;
  if (!v || !v.live) return;
  const $ = (id) => document.getElementById(id);
  const params = new URLSearchParams(location.search);
  const token = params.get('token') || '';
  const host = params.get('live') || location.host;
  const httpBase = params.get('live') ? 'http://' + host : '';
  const withToken = (path) => path + (token ? '?token=' + encodeURIComponent(token) : '');
  const state = { connected: false, connects: 0, messages: 0, mapPoints: 0, frame: -1, status: null,
                  lastSeq: -1, hazardsOrigin: null, lastSave: null, mapCorrections: 0, pointsMoved: 0 };
  let track = [], trackDirty = false, lastFit = 0, fitTimer = null;
  $('live-panel').hidden = false;

  function bytes(base64) {
    const text = atob(base64), out = new Uint8Array(text.length);
    for (let i = 0; i < text.length; ++i) out[i] = text.charCodeAt(i);
    return out;
  }

  // Map segments (live_map_voxels.hpp): each point is kept in its segment's anchor coordinates
  // (per class, in the order the viewer's group holds them) and drawn at the segment's newest
  // pose [x, y, z, qx, qy, qz, qw]; an "anchors" message moves whole segments.
  const anchors = new Map();  // segment -> pose
  const kept = new Map();     // class id -> { local: Float32Array, seg: Uint32Array, n }
  // v' = v + 2w (u × v) + 2 u × (u × v), u = (qx, qy, qz); w negated for the inverse rotation.
  function rotate(q, w, x, y, z, out) {
    const tx = 2 * (q[4] * z - q[5] * y), ty = 2 * (q[5] * x - q[3] * z), tz = 2 * (q[3] * y - q[4] * x);
    out[0] = x + w * tx + (q[4] * tz - q[5] * ty);
    out[1] = y + w * ty + (q[5] * tx - q[3] * tz);
    out[2] = z + w * tz + (q[3] * ty - q[4] * tx);
  }
  function toWorld(pose, x, y, z, out) {
    rotate(pose, pose[6], x, y, z, out);
    out[0] += pose[0]; out[1] += pose[1]; out[2] += pose[2];
  }
  function toLocal(pose, x, y, z, out) { rotate(pose, -pose[6], x - pose[0], y - pose[1], z - pose[2], out); }
  function keep(id, local, seg) {
    let k = kept.get(id);
    if (!k) kept.set(id, k = { local: new Float32Array(3 * 4096), seg: new Uint32Array(4096), n: 0 });
    const n = seg.length;
    if (k.n + n > k.seg.length) {
      const cap = Math.max(2 * k.seg.length, k.n + n), l = new Float32Array(3 * cap), s = new Uint32Array(cap);
      l.set(k.local.subarray(0, 3 * k.n)); s.set(k.seg.subarray(0, k.n));
      k.local = l; k.seg = s;
    }
    k.local.set(local, 3 * k.n);
    k.seg.set(seg, k.n);
    k.n += n;
  }

  // A "map" message: int16 voxel indices (little-endian) and rgb bytes, grouped by class, of one
  // segment, at the segment's pose m.pose.
  function onMap(m) {
    if (m.seq <= state.lastSeq) return;  // had it in the snapshot already
    state.lastSeq = m.seq;
    if (!anchors.has(m.segment)) anchors.set(m.segment, m.pose);
    const drawAt = anchors.get(m.segment);
    const raw = bytes(m.xyz), rgb = bytes(m.rgb), view = new DataView(raw.buffer), p = [0, 0, 0];
    let at = 0;
    for (const g of m.groups) {
      const xyz = new Float32Array(3 * g.count), local = new Float32Array(3 * g.count);
      for (let i = 0; i < g.count; ++i) {
        const c = (k) => (view.getInt16(2 * (3 * (at + i) + k), true) + 0.5) * m.voxel;
        toLocal(m.pose, c(0), c(1), c(2), p);
        local.set(p, 3 * i);
        toWorld(drawAt, p[0], p[1], p[2], p);
        xyz.set(p, 3 * i);
      }
      v.live.addPoints({ id: g.id, name: g.name, kind: g.kind, css: g.css }, xyz, rgb.subarray(3 * at, 3 * (at + g.count)));
      keep(g.id, local, new Uint32Array(g.count).fill(m.segment));
      at += g.count;
    }
    state.mapPoints += at;
    fitSoon();
  }

  // The view follows the map as it grows (until the user moves it), at most once a second; the
  // last growth of a burst is fitted a second later, so the newest points are always in view.
  function fitSoon() {
    if (v.live.userMoved || fitTimer) return;
    const wait = 1000 - (performance.now() - lastFit);
    const fit = () => { fitTimer = null; lastFit = performance.now(); if (!v.live.userMoved) v.live.fit(true); };
    if (wait <= 0) fit();
    else fitTimer = setTimeout(fit, wait);
  }

  // An "anchors" message: segments (uint32 LE) moved to poses (7 float32 LE each).
  function onAnchors(m) {
    const ids = new DataView(bytes(m.segments).buffer), poses = new DataView(bytes(m.poses).buffer), moved = new Set();
    for (let i = 0; i < m.count; ++i) {
      const pose = [];
      for (let k = 0; k < 7; ++k) pose.push(poses.getFloat32(4 * (7 * i + k), true));
      anchors.set(ids.getUint32(4 * i, true), pose);
      moved.add(ids.getUint32(4 * i, true));
    }
    for (const [id, k] of kept)
      state.pointsMoved += v.live.movePoints(id, (i, out) => {
        if (i >= k.n || !moved.has(k.seg[i])) return false;
        toWorld(anchors.get(k.seg[i]), k.local[3 * i], k.local[3 * i + 1], k.local[3 * i + 2], out);
        return true;
      });
    ++state.mapCorrections;
  }

  function flushTrack() {
    if (!trackDirty) return;
    trackDirty = false;
    v.live.setTrajectory('estimate', track.filter((p) => p));
  }

  const fmt = (x, d) => (x === null || x === undefined ? '–' : Number(x).toFixed(d));
  function onStatus(s) {
    state.status = s;
    const el = $('live-status');
    el.classList.toggle('waiting', s.state.startsWith('waiting'));
    el.textContent = s.state + (s.tracking ? ' (' + s.tracking + ')' : '') + '\n' +
      'frames ' + s.frames + ' · ' + fmt(s.frames_per_s, 1) + ' frames/s' +
      (s.back_end_backlog ? ' · back end ' + s.back_end_backlog + ' frames behind' : '') + '\n' +
      'packets ' + s.packets + ' · drops ' + s.drops + ' · queue ' + s.queue_datagrams + ' (' +
      fmt(s.queue_bytes / 1024, 0) + ' kB)\n' +
      'last packet ' + (s.last_packet_age_s === null ? 'never' : fmt(s.last_packet_age_s, 2) + ' s ago') +
      ' · hazards ' + s.hazards + ' · map ' + s.map_points.toLocaleString('en-US') + ' pts' +
      (s.map_corrections ? ' (moved by ' + s.map_corrections + ' corrections)' : '') +
      (s.latency_ms ? '\nlatency ' + fmt(s.latency_ms.p50, 0) + ' / ' + fmt(s.latency_ms.p99, 0) + ' / ' +
        fmt(s.latency_ms.max, 0) + ' ms (p50 / p99 / max, last ' + s.latency_ms.frames + ' frames)' : '') +
      (s.cameras || []).map((c) => '\ncamera ' + c.name + ': ' + c.frames + ' frames' +
        (c.stalled ? ' · STALLED' : ' · last ' + fmt(c.last_frame_age_s, 2) + ' s ago') +
        (c.scans_without_image ? ' · ' + c.scans_without_image + ' scans without a frame' : '') +
        (c.last_error ? ' · ' + c.last_error : '')).join('');
    if (s.last_save) $('live-save').textContent = 'last save: ' + s.last_save;
  }

  function summary() {
    v.live.setSummary(state.mapPoints.toLocaleString('en-US') + ' map points, ' + v.hazardRows().length +
                      ' hazards — live' + (state.frame >= 0 ? ', frame ' + state.frame : ''));
  }

  function handle(m) {
    switch (m.type) {
      case 'map': onMap(m); break;
      case 'anchors': onAnchors(m); break;
      case 'track': track[m.frame] = m.p; trackDirty = true; break;
      case 'trajectory': track = m.points.slice(); trackDirty = true; break;
      case 'pose': state.frame = m.frame; v.live.setRobot(m.p, m.yaw); break;
      case 'hazards': state.hazardsOrigin = m.origin; v.live.setHazards(m.hazards); break;
      case 'status': onStatus(m.status); break;
      default: break;
    }
  }

  function reset() {
    state.lastSeq = -1;
    state.mapPoints = 0;
    state.mapCorrections = 0;
    state.pointsMoved = 0;
    anchors.clear();
    kept.clear();
    state.frame = -1;
    track = [];
    trackDirty = true;
    v.live.clearPoints();
    v.live.setHazards([]);
  }

  function connect() {
    const ws = new WebSocket('ws://' + host + withToken('/ws'));
    $('live-connection').textContent = '(connecting…)';
    ws.onopen = () => {
      state.connected = true;
      ++state.connects;
      reset();
      $('live-connection').textContent = '(connected)';
    };
    ws.onmessage = (e) => {
      ++state.messages;
      handle(JSON.parse(e.data));
    };
    ws.onclose = () => {
      state.connected = false;
      $('live-connection').textContent = '(disconnected: retrying)';
      setTimeout(connect, 1000);
    };
  }

  async function save() {
    $('live-save').textContent = 'saving…';
    try {
      const r = await fetch(httpBase + withToken('/save'), { method: 'POST' });
      state.lastSave = await r.json();
      $('live-save').textContent = state.lastSave.saved ? 'saved to ' + state.lastSave.saved : JSON.stringify(state.lastSave);
    } catch (e) {
      state.lastSave = { error: String(e) };
      $('live-save').textContent = 'save failed: ' + e;
    }
    return state.lastSave;
  }
  $('btn-save').addEventListener('click', save);

  setInterval(() => { flushTrack(); summary(); }, 200);
  connect();
  window.hazmapLive = Object.assign(state, { save, flush() { flushTrack(); summary(); v.renderNow(); } });
})();
