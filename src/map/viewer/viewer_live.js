// hazmap live view: the viewer page connected to `hazmap live` over its WebSocket (/ws): new map
// voxels, the trajectory (redrawn whole after loop corrections), the robot's pose, the hazards
// with their values and the status line. On every (re)connection the server sends its snapshot
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
                  lastSeq: -1, hazardsOrigin: null, lastSave: null };
  let track = [], trackDirty = false, lastFit = 0;
  $('live-panel').hidden = false;

  function bytes(base64) {
    const text = atob(base64), out = new Uint8Array(text.length);
    for (let i = 0; i < text.length; ++i) out[i] = text.charCodeAt(i);
    return out;
  }

  // A "map" message: int16 voxel indices (little-endian) and rgb bytes, grouped by class.
  function onMap(m) {
    if (m.seq <= state.lastSeq) return;  // had it in the snapshot already
    state.lastSeq = m.seq;
    const raw = bytes(m.xyz), rgb = bytes(m.rgb), view = new DataView(raw.buffer);
    let at = 0;
    for (const g of m.groups) {
      const xyz = new Float32Array(3 * g.count);
      for (let i = 0; i < 3 * g.count; ++i) xyz[i] = (view.getInt16(2 * (3 * at + i), true) + 0.5) * m.voxel;
      v.live.addPoints({ id: g.id, name: g.name, kind: g.kind, css: g.css }, xyz, rgb.subarray(3 * at, 3 * (at + g.count)));
      at += g.count;
    }
    state.mapPoints += at;
    const now = performance.now();
    if (!v.live.userMoved && now - lastFit > 1000) { lastFit = now; v.live.fit(true); }
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
      'frames ' + s.frames + ' · ' + fmt(s.frames_per_s, 1) + ' frames/s\n' +
      'packets ' + s.packets + ' · drops ' + s.drops + ' · queue ' + s.queue_datagrams + ' (' +
      fmt(s.queue_bytes / 1024, 0) + ' kB)\n' +
      'last packet ' + (s.last_packet_age_s === null ? 'never' : fmt(s.last_packet_age_s, 2) + ' s ago') +
      ' · hazards ' + s.hazards + ' · map ' + s.map_points.toLocaleString('en-US') + ' pts' +
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
