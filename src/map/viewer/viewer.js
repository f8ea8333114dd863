// hazmap viewer: the map's points (one layer per class), trajectories, hazard boxes and table,
// point inspection, a distance tool, top-down and perspective views. World frame: z up, metres.
// Points are stored relative to meta.center so that float32 keeps millimetres far from origin.
// window.hazmapViewer exposes the state and a few actions for tests and scripting.
(function () {
  'use strict';
  const meta = JSON.parse(document.getElementById('hazmap-meta').textContent);
  const $ = (id) => document.getElementById(id);
  const center = new THREE.Vector3().fromArray(meta.center);
  const fmt = (v, d = 2) => (Math.abs(v) < 0.5 * Math.pow(10, -d) ? 0 : v).toFixed(d);
  const hex = (rgb) => '#' + rgb.map((c) => c.toString(16).padStart(2, '0')).join('');
  const state = { mode: 'perspective', measuring: false, measure: [], lastDistance: null, picked: null,
                  selectedHazard: null, flying: null, moving: false, detail: 1, pointSize: 2, clipZ: null };

  // ---- embedded binary data --------------------------------------------------------------------
  function decodeBase64(id) {
    const el = $(id);
    const text = atob(el ? el.textContent.trim() : '');
    const bytes = new Uint8Array(text.length);
    for (let i = 0; i < text.length; ++i) bytes[i] = text.charCodeAt(i);
    return bytes;
  }
  function decodePoints() {
    const q = new Uint16Array(decodeBase64('hazmap-positions').buffer);
    const colors = decodeBase64('hazmap-colors');
    const property = meta.has_property ? new Float32Array(decodeBase64('hazmap-property').buffer) : null;
    const n = meta.points_embedded;
    if (q.length !== 3 * n || colors.length !== 3 * n) throw new Error('hazmap viewer: embedded map is corrupt');
    const xyz = new Float32Array(3 * n);
    for (let i = 0; i < 3 * n; ++i) {
      const k = i % 3;
      xyz[i] = meta.qmin[k] + q[i] * meta.qstep[k] - meta.center[k];
    }
    return { xyz, colors, property, n };
  }

  // ---- scene -----------------------------------------------------------------------------------
  const canvas = $('canvas');
  const renderer = new THREE.WebGLRenderer({ canvas, antialias: true, preserveDrawingBuffer: true });
  renderer.setPixelRatio(window.devicePixelRatio || 1);
  renderer.localClippingEnabled = true;
  const scene = new THREE.Scene();
  scene.background = new THREE.Color(meta.background || '#1b1e23');
  const clipPlane = new THREE.Plane(new THREE.Vector3(0, 0, -1), 1e9);
  const data = decodePoints();
  const bounds = new THREE.Box3();
  for (let i = 0; i < data.n; ++i)
    bounds.expandByPoint(new THREE.Vector3(data.xyz[3 * i], data.xyz[3 * i + 1], data.xyz[3 * i + 2]));
  if (bounds.isEmpty()) bounds.set(new THREE.Vector3(-5, -5, -1), new THREE.Vector3(5, 5, 1));

  // One THREE.Points per class group; a group's points are shuffled, so drawing its first k
  // points is an even decimation (level of detail).
  function makeGroup(g, xyz, colors) {
    const geometry = new THREE.BufferGeometry();
    geometry.setAttribute('position', new THREE.BufferAttribute(xyz, 3));
    geometry.setAttribute('color', new THREE.BufferAttribute(colors, 3, true));
    const material = new THREE.PointsMaterial({ size: 2, sizeAttenuation: false, vertexColors: THREE.VertexColors,
                                                clippingPlanes: [clipPlane] });
    const points = new THREE.Points(geometry, material);
    points.frustumCulled = false;
    scene.add(points);
    return Object.assign({}, g, { points, material, geometry, visible: true, drawn: g.count });
  }
  const groups = meta.groups.map((g) => makeGroup(g, data.xyz.subarray(3 * g.offset, 3 * (g.offset + g.count)),
                                                  data.colors.subarray(3 * g.offset, 3 * (g.offset + g.count))));

  const trajectories = meta.trajectories.map((t) => {
    const geometry = new THREE.BufferGeometry();
    const xyz = new Float32Array(t.points.length * 3);
    t.points.forEach((p, i) => { for (let k = 0; k < 3; ++k) xyz[3 * i + k] = p[k] - meta.center[k]; });
    geometry.setAttribute('position', new THREE.BufferAttribute(xyz, 3));
    const line = new THREE.Line(geometry, new THREE.LineBasicMaterial({ color: t.color, depthTest: false }));
    line.renderOrder = t.name === 'estimate' ? 3 : 2;  // the estimate over the ground truth
    scene.add(line);
    const start = new THREE.Mesh(new THREE.SphereGeometry(1, 12, 8), new THREE.MeshBasicMaterial({ color: t.color, depthTest: false }));
    if (t.points.length) start.position.set(xyz[0], xyz[1], xyz[2]);
    start.renderOrder = 2;
    scene.add(start);
    return Object.assign({}, t, { line, start, visible: true });
  });

  const hazardObject = (h) => {
    const box = new THREE.Box3(new THREE.Vector3().fromArray(h.min).sub(center), new THREE.Vector3().fromArray(h.max).sub(center));
    const helper = new THREE.Box3Helper(box, new THREE.Color(h.color));
    helper.material.depthTest = false;
    helper.renderOrder = 3;
    scene.add(helper);
    const label = document.createElement('div');
    label.className = 'hz-label';
    label.textContent = '#' + h.id + ' ' + h.class;
    label.style.color = h.color;
    label.style.borderColor = h.color;
    $('labels').appendChild(label);
    const top = new THREE.Vector3(0.5 * (box.min.x + box.max.x), 0.5 * (box.min.y + box.max.y), box.max.z);
    return { hazard: h, helper, label, top, centroid: new THREE.Vector3().fromArray(h.centroid).sub(center) };
  };
  let hazardObjects = meta.hazards.map(hazardObject);
  let hazardsVisible = true;

  // Changes since the prior mission (changes.json of a run with --prior or of a merge): a ring
  // where each hazard is now (or was, when gone), an arrow from before to after when it moved.
  const CHANGE_COLORS = { new: '#3cdc6e', gone: '#ff3c3c', moved: '#ffa01e', grown: '#f0e040', shrunk: '#f0e040',
                          value_changed: '#e040f0', not_re_observed: '#8a8f98', unchanged: '#5a7fa8', part_of: '#5a7fa8' };
  const QUIET_KINDS = ['unchanged', 'part_of', 'not_re_observed'];
  const changeKind = (c) => c.kinds.find((k) => !QUIET_KINDS.includes(k)) || c.kinds[0];
  const changeObject = (c) => {
    const kind = changeKind(c), color = new THREE.Color(CHANGE_COLORS[kind] || '#ffffff');
    const material = new THREE.MeshBasicMaterial({ color, depthTest: false, side: THREE.DoubleSide });
    const position = new THREE.Vector3().fromArray(c.after || c.before).sub(center);
    const group = new THREE.Group();
    const ring = new THREE.Mesh(new THREE.RingGeometry(0.55, 0.8, 40), material);
    ring.position.copy(position);
    group.add(ring);
    if (c.before && c.after && c.kinds.includes('moved')) {
      const from = new THREE.Vector3().fromArray(c.before).sub(center), dir = position.clone().sub(from);
      const arrow = new THREE.ArrowHelper(dir.clone().normalize(), from, dir.length(), color.getHex(), 0.5, 0.35);
      arrow.line.material.depthTest = false;
      arrow.cone.material.depthTest = false;
      group.add(arrow);
    }
    group.traverse((o) => { o.renderOrder = 4; });
    group.visible = !QUIET_KINDS.includes(kind);
    scene.add(group);
    return { change: c, kind, group, position };
  };
  const changeObjects = (meta.changes || []).map(changeObject)
    .sort((a, b) => QUIET_KINDS.includes(a.kind) - QUIET_KINDS.includes(b.kind));
  let changesVisible = true;

  // Markers of the selection and of the distance tool.
  const markerMaterial = new THREE.MeshBasicMaterial({ color: 0xffffff, depthTest: false });
  const pickMarker = new THREE.Mesh(new THREE.SphereGeometry(1, 16, 10), markerMaterial);
  pickMarker.visible = false;
  pickMarker.renderOrder = 4;
  scene.add(pickMarker);
  const measureGeometry = new THREE.BufferGeometry();
  measureGeometry.setAttribute('position', new THREE.BufferAttribute(new Float32Array(6), 3));
  const measureLine = new THREE.Line(measureGeometry, new THREE.LineBasicMaterial({ color: 0xffffff, depthTest: false }));
  measureLine.visible = false;
  measureLine.renderOrder = 4;
  scene.add(measureLine);
  const measureMarkers = [0, 1].map(() => {
    const m = new THREE.Mesh(new THREE.SphereGeometry(1, 16, 10), markerMaterial);
    m.visible = false;
    m.renderOrder = 4;
    scene.add(m);
    return m;
  });
  const measureLabel = document.createElement('div');
  measureLabel.className = 'measure-label';
  measureLabel.style.display = 'none';
  $('labels').appendChild(measureLabel);

  // ---- cameras ---------------------------------------------------------------------------------
  let size = bounds.getSize(new THREE.Vector3());
  let span = Math.max(size.x, size.y, size.z, 1);
  const perspective = new THREE.PerspectiveCamera(50, 1, span / 2000, span * 20);
  perspective.up.set(0, 0, 1);
  const ortho = new THREE.OrthographicCamera(-1, 1, 1, -1, -span * 10, span * 10);
  ortho.up.set(0, 1, 0);
  const controlsFor = (camera, rotate) => {
    const c = new THREE.OrbitControls(camera, canvas);
    c.enableRotate = rotate;
    c.screenSpacePanning = true;
    c.enableDamping = false;
    c.addEventListener('change', requestRender);
    c.addEventListener('start', () => { state.moving = true; state.userMoved = true; applyDetail(); });
    c.addEventListener('end', () => { state.moving = false; applyDetail(); requestRender(); });
    return c;
  };
  const controls = { perspective: controlsFor(perspective, true), top: controlsFor(ortho, false) };
  const camera = () => (state.mode === 'top' ? ortho : perspective);
  const activeControls = () => (state.mode === 'top' ? controls.top : controls.perspective);

  function resize() {
    const w = canvas.clientWidth || 800, h = canvas.clientHeight || 600;
    renderer.setSize(w, h, false);
    perspective.aspect = w / h;
    perspective.updateProjectionMatrix();
    const half = 0.5 * span;
    ortho.left = -half * w / h; ortho.right = half * w / h; ortho.top = half; ortho.bottom = -half;
    ortho.updateProjectionMatrix();
    requestRender();
  }

  // Metres per screen pixel at the orbit target.
  function metresPerPixel() {
    const h = canvas.clientHeight || 600;
    if (state.mode === 'top') return (ortho.top - ortho.bottom) / ortho.zoom / h;
    const d = perspective.position.distanceTo(controls.perspective.target);
    return 2 * d * Math.tan((perspective.fov / 2 * Math.PI / 180)) / h;
  }

  function setMode(mode, keepTarget) {
    const target = (keepTarget ? activeControls().target.clone() : bounds.getCenter(new THREE.Vector3()));
    const distance = keepTarget ? metresPerPixel() * (canvas.clientHeight || 600) : fitExtent();
    state.mode = mode;
    controls.perspective.enabled = mode === 'perspective';
    controls.top.enabled = mode === 'top';
    placeCamera(target, distance);
    $('btn-top').classList.toggle('active', mode === 'top');
    $('btn-persp').classList.toggle('active', mode === 'perspective');
    requestRender();
  }

  // The extent that fits the map's footprint in the view (its height, or its width / aspect).
  function fitExtent() {
    const aspect = (canvas.clientWidth || 800) / (canvas.clientHeight || 600);
    return Math.max(size.y, size.x / aspect, 1) * (state.mode === 'top' ? 1.05 : 1.25);
  }

  // Looks at `target` so that about `extent` metres fit the view's height.
  function placeCamera(target, extent) {
    if (state.mode === 'top') {
      controls.top.target.copy(target);
      ortho.position.set(target.x, target.y, target.z + span * 4);
      ortho.zoom = (ortho.top - ortho.bottom) / Math.max(extent, 0.5);
      ortho.updateProjectionMatrix();
      ortho.lookAt(target);
      controls.top.update();
    } else {
      const d = Math.max(extent, 0.5) / (2 * Math.tan((perspective.fov / 2 * Math.PI / 180)));
      controls.perspective.target.copy(target);
      perspective.position.copy(target).add(new THREE.Vector3(-0.45, -0.75, 0.5).normalize().multiplyScalar(d));
      controls.perspective.update();
    }
    updateMarkerSizes();
  }

  // Animated flight to a new target and extent (~0.6 s); `instant` jumps.
  function flyTo(target, extent, instant) {
    const c = activeControls(), cam = camera();
    const from = { target: c.target.clone(), position: cam.position.clone(), zoom: cam.zoom };
    placeCamera(target, extent);
    const to = { target: c.target.clone(), position: cam.position.clone(), zoom: cam.zoom };
    if (instant) { requestRender(); return; }
    c.target.copy(from.target); cam.position.copy(from.position); cam.zoom = from.zoom;
    const flight = { from, to, start: performance.now(), duration: 600 };
    state.flying = flight;
    // Frames may be throttled (a background tab, a headless browser): land on time regardless.
    setTimeout(() => { if (state.flying === flight) { flight.start = -1e9; stepFlight(performance.now()); renderNow(); } }, flight.duration + 50);
    requestRender();
  }

  function stepFlight(now) {
    const f = state.flying;
    if (!f) return;
    const t = Math.max(0, Math.min(1, (now - f.start) / f.duration)), s = t * t * (3 - 2 * t);
    const c = activeControls(), cam = camera();
    c.target.lerpVectors(f.from.target, f.to.target, s);
    cam.position.lerpVectors(f.from.position, f.to.position, s);
    cam.zoom = f.from.zoom + (f.to.zoom - f.from.zoom) * s;
    cam.updateProjectionMatrix();
    c.update();
    if (t >= 1) state.flying = null;
  }

  // ---- level of detail, point size, clipping ---------------------------------------------------
  function applyDetail() {
    const total = groups.reduce((a, g) => a + (g.visible ? g.count : 0), 0);
    // While the camera moves, at most meta.moving_budget points are drawn.
    const moving = state.moving && total * state.detail > meta.moving_budget ? meta.moving_budget / (total * state.detail) : 1;
    for (const g of groups) {
      g.drawn = Math.min(g.count, Math.ceil(g.count * state.detail * moving));
      g.geometry.setDrawRange(0, g.drawn);
      g.points.visible = g.visible;
    }
    requestRender();
  }
  function setPointSize(px) {
    state.pointSize = px;
    for (const g of groups) g.material.size = px * (g.kind === 'none' ? 1 : 1.5);
    requestRender();
  }
  function setClip(z) {
    state.clipZ = z;
    clipPlane.constant = z === null ? 1e9 : z - center.z;
    requestRender();
  }

  // ---- picking ---------------------------------------------------------------------------------
  // The drawn, unclipped point nearest to the camera within `radiusPx` of the screen position.
  function pickAt(sx, sy, radiusPx = 6) {
    const cam = camera();
    const w = canvas.clientWidth, h = canvas.clientHeight;
    const ndc = new THREE.Vector3((sx / w) * 2 - 1, -(sy / h) * 2 + 1, -1);
    const ray = new THREE.Ray();
    if (cam.isOrthographicCamera) {
      ray.origin.copy(ndc).unproject(cam);
      ray.direction.set(0, 0, -1).transformDirection(cam.matrixWorld);
    } else {
      ray.origin.setFromMatrixPosition(cam.matrixWorld);
      ray.direction.copy(ndc).unproject(cam).sub(ray.origin).normalize();
    }
    const radPerPx = cam.isOrthographicCamera ? 0 : 2 * Math.tan((cam.fov / 2 * Math.PI / 180)) / h;
    const mpp = cam.isOrthographicCamera ? (cam.top - cam.bottom) / cam.zoom / h : 0;
    const o = ray.origin, d = ray.direction, clipLocal = clipPlane.constant;
    let best = null;
    for (const g of groups) {
      if (!g.visible) continue;
      const xyz = g.geometry.attributes.position.array;
      for (let i = 0; i < g.drawn; ++i) {
        const x = xyz[3 * i] - o.x, y = xyz[3 * i + 1] - o.y, z = xyz[3 * i + 2] - o.z;
        if (xyz[3 * i + 2] > clipLocal) continue;
        const t = x * d.x + y * d.y + z * d.z;
        if (t <= 0 || (best && t >= best.t)) continue;
        const perp2 = x * x + y * y + z * z - t * t;
        const tol = radiusPx * (cam.isOrthographicCamera ? mpp : radPerPx * t);
        if (perp2 <= tol * tol) best = { t, group: g, index: i };
      }
    }
    if (!best) return null;
    const i = best.index, g = best.group, xyz = g.geometry.attributes.position.array;
    const local = new THREE.Vector3(xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]);
    const world = local.clone().add(center);
    const value = data.property ? data.property[g.offset + i] : null;
    return { world: world.toArray(), local, class: g.name, class_id: g.id, kind: g.kind,
             property: value, index: g.offset + i };
  }

  function showPick(p) {
    state.picked = p ? { world: p.world, class: p.class, class_id: p.class_id, property: p.property } : null;
    pickMarker.visible = !!p;
    if (!p) { $('pick').textContent = 'No map point there.'; requestRender(); return; }
    pickMarker.position.copy(p.local);
    const value = p.property === null ? '' : '<br>property value: ' + fmt(p.property, 2);
    $('pick').innerHTML = 'x ' + fmt(p.world[0], 3) + '  y ' + fmt(p.world[1], 3) + '  z ' + fmt(p.world[2], 3) + ' m' +
      '<br>class: <b>' + p.class + '</b> (' + p.kind + ', id ' + p.class_id + ')' + value;
    requestRender();
  }

  function addMeasurePoint(p) {
    if (!p) return;
    if (state.measure.length === 2) state.measure = [];
    state.measure.push(p);
    measureMarkers.forEach((m, k) => {
      m.visible = k < state.measure.length;
      if (m.visible) m.position.copy(state.measure[k].local);
    });
    if (state.measure.length === 2) {
      const [a, b] = state.measure;
      state.lastDistance = a.local.distanceTo(b.local);
      const arr = measureGeometry.attributes.position.array;
      a.local.toArray(arr, 0);
      b.local.toArray(arr, 3);
      measureGeometry.attributes.position.needsUpdate = true;
      measureLine.visible = true;
      $('distance').textContent = 'Distance: ' + fmt(state.lastDistance, 3) + ' m (horizontal ' +
        fmt(Math.hypot(a.world[0] - b.world[0], a.world[1] - b.world[1]), 3) + ' m, height ' +
        fmt(b.world[2] - a.world[2], 3) + ' m)';
    } else {
      measureLine.visible = false;
      $('distance').textContent = 'First point set: click the second.';
    }
    requestRender();
  }

  function clearSelection() {
    state.measure = [];
    state.picked = null;
    measureMarkers.forEach((m) => { m.visible = false; });
    measureLine.visible = false;
    pickMarker.visible = false;
    $('distance').textContent = '';
    $('pick').textContent = 'Click a map point to see its coordinates, class and property value.';
    requestRender();
  }

  function clickScreen(sx, sy) {
    const p = pickAt(sx, sy);
    showPick(p);
    if (state.measuring) addMeasurePoint(p);
    return p;
  }

  function toScreen(world) {
    const v = new THREE.Vector3().fromArray(world).sub(center).project(camera());
    return [(v.x + 1) / 2 * canvas.clientWidth, (1 - v.y) / 2 * canvas.clientHeight, v.z];
  }

  // ---- side panel ------------------------------------------------------------------------------
  function buildLegend() {
    const legend = $('legend');
    legend.textContent = '';
    const item = (swatchClass, color, text, count, checked, onToggle) => {
      const row = document.createElement('label');
      row.className = 'legend-item';
      const box = document.createElement('input');
      box.type = 'checkbox';
      box.checked = checked;
      box.addEventListener('change', () => onToggle(box.checked));
      const swatch = document.createElement('span');
      swatch.className = 'swatch ' + swatchClass;
      if (color) swatch.style.background = color;
      const name = document.createElement('span');
      name.textContent = text;
      const n = document.createElement('span');
      n.className = 'count';
      n.textContent = count;
      row.append(box, swatch, name, n);
      legend.appendChild(row);
      box.countEl = n;  // live updates rewrite the count
      return box;
    };
    for (const g of groups) {
      const label = g.kind === 'none' ? g.name + ' (grey by height)' : g.name;
      g.checkbox = item(g.kind === 'none' ? 'grey' : '', g.kind === 'none' ? null : g.css, label,
                        g.count.toLocaleString('en-US') + ' pts', g.visible, (on) => setClassVisible(g.id, on));
    }
    for (const t of trajectories)
      t.checkbox = item('line', t.color, t.name + ' trajectory', t.points.length + ' poses', t.visible, (on) => {
        t.visible = on; t.line.visible = on; t.start.visible = on; requestRender();
      });
    item('', 'transparent', 'hazard boxes and labels', meta.hazards.length, hazardsVisible, (on) => {
      hazardsVisible = on;
      for (const o of hazardObjects) { o.helper.visible = on; }
      requestRender();
    });
    const shown = changeObjects.filter((o) => !QUIET_KINDS.includes(o.kind));
    if (changeObjects.length)
      item('', CHANGE_COLORS.moved, 'changes since the prior mission', shown.length, changesVisible, (on) => {
        changesVisible = on;
        for (const o of shown) o.group.visible = on;
        requestRender();
      });
  }

  function changeDetail(c) {
    const parts = [];
    if (c.mission) parts.push('mission ' + c.mission);
    if (c.kinds.includes('moved')) parts.push(fmt(c.moved_m, 2) + ' m from ' + c.before.slice(0, 2).map((v) => fmt(v, 1)).join(', '));
    if (c.kinds.includes('grown') || c.kinds.includes('shrunk')) parts.push(fmt(c.area_before_m2, 2) + ' → ' + fmt(c.area_after_m2, 2) + ' m²');
    if (c.kinds.includes('value_changed') && c.value_before !== null && c.value_after !== null)
      parts.push(fmt(c.value_before, 1) + ' → ' + fmt(c.value_after, 1));
    if (c.kinds.includes('gone') || c.kinds.includes('new')) parts.push(fmt(c.area_before_m2 || c.area_after_m2, 2) + ' m²');
    return parts.join('; ');
  }

  function buildChangeTable() {
    if (!changeObjects.length) return;
    $('changes-section').hidden = false;
    const body = $('changes').querySelector('tbody');
    body.textContent = '';
    changeObjects.forEach((o, k) => {
      const c = o.change, tr = document.createElement('tr');
      const where = (c.after || c.before).slice(0, 2).map((v) => fmt(v, 1)).join(', ');
      const cells = ['<span class="dot" style="background:' + (CHANGE_COLORS[o.kind] || '#fff') + '"></span>' +
        '<span class="change-kind">' + c.kinds.join(', ').replace(/_/g, ' ') + '</span>', c.class, where, changeDetail(c),
        fmt(c.confidence, 2)];
      tr.innerHTML = cells.map((t) => '<td>' + t + '</td>').join('');
      tr.classList.toggle('quiet', QUIET_KINDS.includes(o.kind));
      tr.addEventListener('click', () => flyTo(o.position.clone(), 8));
      body.appendChild(tr);
    });
    $('change-count').textContent = '(' + changeObjects.filter((o) => !QUIET_KINDS.includes(o.kind)).length + ')';
  }

  function buildHazardTable() {
    const body = $('hazards').querySelector('tbody');
    body.textContent = '';
    meta.hazards.forEach((h, k) => {
      const tr = document.createElement('tr');
      const ext = h.max.map((v, i) => v - h.min[i]);
      const cells = ['<span class="dot" style="background:' + h.color + '"></span>' + h.id, h.class,
        h.centroid.map((v) => fmt(v, 1)).join(', '), ext.map((v) => fmt(v, 1)).join('×'), fmt(h.area_m2, 2),
        h.mean_property === null ? '–' : fmt(h.mean_property, 1)];
      tr.innerHTML = cells.map((c) => '<td>' + c + '</td>').join('');
      tr.addEventListener('click', () => selectHazard(k));
      body.appendChild(tr);
    });
    $('hazard-count').textContent = '(' + meta.hazards.length + ')';
  }

  function selectHazard(k, instant) {
    const o = hazardObjects[k];
    if (!o) return false;
    state.selectedHazard = k;
    $('hazards').querySelectorAll('tbody tr').forEach((tr, i) => tr.classList.toggle('selected', i === k));
    const h = o.hazard, ext = Math.max(h.max[0] - h.min[0], h.max[1] - h.min[1], h.max[2] - h.min[2]);
    flyTo(o.centroid.clone(), Math.max(4 * ext, 6), instant);
    return true;
  }

  function setClassVisible(id, on) {
    for (const g of groups) if (g.id === id) { g.visible = on; if (g.checkbox) g.checkbox.checked = on; }
    applyDetail();
  }

  function showDetail() {
    const n = groups.reduce((a, g) => a + Math.ceil(g.count * state.detail), 0);
    $('detail-val').textContent = n.toLocaleString('en-US');
  }

  function bindControls() {
    $('btn-top').addEventListener('click', () => setMode('top', true));
    $('btn-persp').addEventListener('click', () => setMode('perspective', true));
    $('btn-fit').addEventListener('click', () => flyTo(bounds.getCenter(new THREE.Vector3()), fitExtent()));
    $('btn-measure').addEventListener('click', () => setMeasuring(!state.measuring));
    $('btn-clear').addEventListener('click', clearSelection);
    const sizeInput = $('point-size'), detailInput = $('detail'), clipInput = $('clip');
    sizeInput.value = state.pointSize;
    $('point-size-val').textContent = state.pointSize + ' px';
    sizeInput.addEventListener('input', () => { setPointSize(+sizeInput.value); $('point-size-val').textContent = sizeInput.value + ' px'; });
    detailInput.value = Math.round(state.detail * 100);
    showDetail();
    detailInput.addEventListener('input', () => { state.detail = +detailInput.value / 100; applyDetail(); showDetail(); });
    const zRange = () => [bounds.min.z + center.z, bounds.max.z + center.z];  // a live map's grows
    const toZ = (v) => { const [zlo, zhi] = zRange(); return zlo + (zhi - zlo) * v / 1000; };
    const showClip = () => { $('clip-val').textContent = state.clipZ === null ? 'off' : fmt(state.clipZ, 1) + ' m'; };
    const [zlo, zhi] = zRange();
    clipInput.value = state.clipZ === null ? 1000 : Math.round(1000 * (state.clipZ - zlo) / Math.max(zhi - zlo, 1e-6));
    showClip();
    clipInput.addEventListener('input', () => { setClip(+clipInput.value >= 1000 ? null : toZ(+clipInput.value)); showClip(); });
    let down = null;
    canvas.addEventListener('pointerdown', (e) => { down = [e.clientX, e.clientY]; });
    canvas.addEventListener('pointerup', (e) => {
      if (!down || e.button !== 0) return;
      if (Math.hypot(e.clientX - down[0], e.clientY - down[1]) < 4) {
        const r = canvas.getBoundingClientRect();
        clickScreen(e.clientX - r.left, e.clientY - r.top);
      }
      down = null;
    });
    window.addEventListener('resize', resize);
  }

  function setMeasuring(on) {
    state.measuring = on;
    $('btn-measure').classList.toggle('active', on);
    if (on) { state.measure = []; $('distance').textContent = 'Click two map points.'; }
  }

  // ---- drawing ---------------------------------------------------------------------------------
  function updateMarkerSizes() {
    const r = 5 * metresPerPixel();
    for (const m of [pickMarker, ...measureMarkers]) m.scale.setScalar(r);
    for (const t of trajectories) t.start.scale.setScalar(r);
    if (robot) robot.scale.setScalar(Math.max(0.5, 2 * r));
  }

  function updateOverlays() {
    const w = canvas.clientWidth, h = canvas.clientHeight, cam = camera();
    const place = (el, local, show) => {
      const v = local.clone().project(cam);
      const visible = show && v.z > -1 && v.z < 1 && Math.abs(v.x) < 1.05 && Math.abs(v.y) < 1.05;
      el.style.display = visible ? 'block' : 'none';
      if (visible) { el.style.left = ((v.x + 1) / 2 * w) + 'px'; el.style.top = ((1 - v.y) / 2 * h) + 'px'; }
    };
    for (const o of hazardObjects) place(o.label, o.top, hazardsVisible);
    if (state.measure.length === 2) {
      measureLabel.textContent = fmt(state.lastDistance, 2) + ' m';
      place(measureLabel, state.measure[0].local.clone().lerp(state.measure[1].local, 0.5), true);
    } else {
      measureLabel.style.display = 'none';
    }
    // Scale bar: a 1, 2 or 5 × 10^k metre length of at most 140 px.
    const mpp = metresPerPixel(), raw = mpp * 140, mag = Math.pow(10, Math.floor(Math.log10(raw)));
    const len = [5, 2, 1].map((f) => f * mag).find((l) => l <= raw) || mag;
    $('scalebar-bar').style.width = (len / mpp) + 'px';
    $('scalebar-text').textContent = (len >= 1 ? len : len.toPrecision(1)) + ' m' + (state.mode === 'perspective' ? ' (at the orbit centre)' : '');
  }

  let renderQueued = false;
  function requestRender() {
    if (renderQueued) return;
    renderQueued = true;
    requestAnimationFrame(frame);
  }
  function frame() {
    renderQueued = false;
    stepFlight(performance.now());  // (a frame's own time stamp may use another clock)
    renderNow();
    if (state.flying) requestRender();
  }
  function renderNow() {
    updateMarkerSizes();
    renderer.render(scene, camera());
    updateOverlays();
  }

  // Pixels of the last frame that are close to a colour (tests and screenshots).
  function countPixels(rgb, tolerance = 40) {
    renderNow();
    const gl = renderer.getContext(), w = gl.drawingBufferWidth, h = gl.drawingBufferHeight;
    const px = new Uint8Array(4 * w * h);
    gl.readPixels(0, 0, w, h, gl.RGBA, gl.UNSIGNED_BYTE, px);
    let n = 0;
    for (let i = 0; i < px.length; i += 4)
      if (Math.abs(px[i] - rgb[0]) <= tolerance && Math.abs(px[i + 1] - rgb[1]) <= tolerance && Math.abs(px[i + 2] - rgb[2]) <= tolerance) ++n;
    return n;
  }

  // ---- live updates (viewer_live.js: the live view's page only) ---------------------------------
  // World points (xyz, Float32Array) and their colours (rgb, Uint8Array) join their class's
  // group, whose buffers grow by doubling; the bounds and the camera's depth range grow with them.
  let boundsFromData = data.n > 0, robot = null;
  function updateSpan() {
    size = bounds.getSize(new THREE.Vector3());
    span = Math.max(size.x, size.y, size.z, 1);
    perspective.near = span / 2000; perspective.far = span * 20; perspective.updateProjectionMatrix();
    ortho.near = -span * 10; ortho.far = span * 10; ortho.updateProjectionMatrix();
  }
  function growGroup(g, n) {
    const pos = g.geometry.attributes.position, col = g.geometry.attributes.color;
    if (3 * (g.count + n) <= pos.array.length) return;
    const cap = Math.max(2 * pos.array.length, 3 * (g.count + n));
    const p = new Float32Array(cap), c = new Uint8Array(cap);
    p.set(pos.array.subarray(0, 3 * g.count));
    c.set(col.array.subarray(0, 3 * g.count));
    g.geometry.setAttribute('position', new THREE.BufferAttribute(p, 3));
    g.geometry.setAttribute('color', new THREE.BufferAttribute(c, 3, true));
  }
  function addPoints(info, xyz, rgb) {
    const n = xyz.length / 3;
    if (!n) return;
    let g = groups.find((x) => x.id === info.id);
    if (!g) {
      g = makeGroup(Object.assign({}, info, { offset: 0, count: 0 }), new Float32Array(3 * Math.max(n, 4096)),
                    new Uint8Array(3 * Math.max(n, 4096)));
      groups.push(g);
      setPointSize(state.pointSize);
      buildLegend();
    }
    growGroup(g, n);
    const p = g.geometry.attributes.position, c = g.geometry.attributes.color, at = 3 * g.count;
    if (!boundsFromData) { bounds.makeEmpty(); boundsFromData = true; }
    const v = new THREE.Vector3();
    for (let i = 0; i < n; ++i) {
      v.set(xyz[3 * i] - center.x, xyz[3 * i + 1] - center.y, xyz[3 * i + 2] - center.z).toArray(p.array, at + 3 * i);
      bounds.expandByPoint(v);
    }
    c.array.set(rgb, at);
    g.count += n;
    if (g.checkbox) g.checkbox.countEl.textContent = g.count.toLocaleString('en-US') + ' pts';
    p.needsUpdate = true;
    c.needsUpdate = true;
    updateSpan();
    applyDetail();
    showDetail();
  }
  // Moves a group's points in place (a live map's loop corrections): place(i, out) writes point
  // i's new world position into out and returns true, or returns false to leave it.
  function movePoints(id, place) {
    const g = groups.find((x) => x.id === id);
    if (!g) return 0;
    const p = g.geometry.attributes.position, w = [0, 0, 0], v = new THREE.Vector3();
    let moved = 0;
    for (let i = 0; i < g.count; ++i) {
      if (!place(i, w)) continue;
      v.set(w[0] - center.x, w[1] - center.y, w[2] - center.z).toArray(p.array, 3 * i);
      bounds.expandByPoint(v);
      ++moved;
    }
    p.needsUpdate = true;
    updateSpan();
    requestRender();
    return moved;
  }
  // World positions of a group's points (tests).
  function pointsOf(id) {
    const g = groups.find((x) => x.id === id);
    if (!g) return [];
    const a = g.geometry.attributes.position.array, out = [];
    for (let i = 0; i < g.count; ++i) out.push([a[3 * i] + center.x, a[3 * i + 1] + center.y, a[3 * i + 2] + center.z]);
    return out;
  }
  function clearPoints() {
    for (const g of groups) { scene.remove(g.points); g.geometry.dispose(); }
    groups.length = 0;
    bounds.set(new THREE.Vector3(-5, -5, -1), new THREE.Vector3(5, 5, 1));
    boundsFromData = false;
    updateSpan();
    buildLegend();
    requestRender();
  }
  function setTrajectory(name, points) {
    const t = trajectories.find((x) => x.name === name);
    if (!t) return;
    const xyz = new Float32Array(points.length * 3);
    points.forEach((q, i) => { for (let k = 0; k < 3; ++k) xyz[3 * i + k] = q[k] - center.getComponent(k); });
    t.points = points;
    t.line.geometry.setAttribute('position', new THREE.BufferAttribute(xyz, 3));
    t.line.geometry.computeBoundingSphere();
    if (points.length) t.start.position.set(xyz[0], xyz[1], xyz[2]);
    if (t.checkbox) t.checkbox.countEl.textContent = points.length + ' poses';
    requestRender();
  }
  function setHazards(list) {
    for (const o of hazardObjects) { scene.remove(o.helper); o.label.remove(); }
    meta.hazards = list;
    hazardObjects = list.map(hazardObject);
    for (const o of hazardObjects) o.helper.visible = hazardsVisible;
    state.selectedHazard = null;
    buildHazardTable();
    buildLegend();
    requestRender();
  }
  // The robot: a cone pointing along its heading.
  function setRobot(p, yaw) {
    if (!robot) {
      const cone = new THREE.ConeGeometry(0.35, 1, 16);
      cone.rotateZ(-Math.PI / 2);  // along +x
      robot = new THREE.Mesh(cone, new THREE.MeshBasicMaterial({ color: 0xffa000, depthTest: false }));
      robot.renderOrder = 5;
      scene.add(robot);
    }
    robot.position.set(p[0] - center.x, p[1] - center.y, p[2] - center.z);
    robot.rotation.set(0, 0, yaw);
    updateMarkerSizes();
    requestRender();
  }
  const live = {
    addPoints, movePoints, pointsOf, clearPoints, setTrajectory, setHazards, setRobot,
    groupIds() { return groups.map((g) => g.id); },
    fit(instant) { flyTo(bounds.getCenter(new THREE.Vector3()), fitExtent(), instant !== false); },
    setSummary(text) { $('summary').textContent = text; },
    get userMoved() { return !!state.userMoved; },
  };

  // ---- start -----------------------------------------------------------------------------------
  $('title').textContent = meta.title;
  document.title = meta.title;
  $('summary').textContent = meta.points_embedded.toLocaleString('en-US') + ' map points' +
    (meta.points_embedded < meta.points_total ? ' (evenly decimated from ' + meta.points_total.toLocaleString('en-US') + ')' : '') +
    ', ' + meta.hazards.length + ' hazards' + (meta.source ? ' — ' + meta.source : '');
  state.detail = Math.min(1, meta.detail_budget / Math.max(1, data.n));
  if (meta.clip_above !== null) state.clipZ = meta.clip_above;
  buildLegend();
  buildHazardTable();
  buildChangeTable();
  bindControls();
  setPointSize(state.pointSize);
  setClip(state.clipZ);
  applyDetail();
  resize();
  setMode(meta.initial_view === 'top' ? 'top' : 'perspective', false);
  renderNow();
  $('loading').style.display = 'none';

  window.hazmapViewer = {
    ready: true,
    meta,
    get mode() { return state.mode; },
    get lastDistance() { return state.lastDistance; },
    get picked() { return state.picked; },
    get selectedHazard() { return state.selectedHazard; },
    get flying() { return !!state.flying; },
    camera() {
      const c = activeControls();
      return { position: camera().position.clone().add(center).toArray(), target: c.target.clone().add(center).toArray(),
               zoom: camera().zoom, metresPerPixel: metresPerPixel(), mode: state.mode };
    },
    hazardRows() {
      return Array.from($('hazards').querySelectorAll('tbody tr')).map((tr) => Array.from(tr.cells).map((td) => td.textContent));
    },
    changeRows() {
      return Array.from($('changes').querySelectorAll('tbody tr')).map((tr) => Array.from(tr.cells).map((td) => td.textContent));
    },
    clickChange(k, instant) { const o = changeObjects[k]; if (!o) return false; flyTo(o.position.clone(), 8, instant); return true; },
    setChangesVisible(on) { for (const o of changeObjects) if (!QUIET_KINDS.includes(o.kind)) o.group.visible = on; renderNow(); },
    clickRow(k, instant) { const tr = $('hazards').querySelectorAll('tbody tr')[k]; if (!tr) return false;
      if (instant) return selectHazard(k, true); tr.click(); return true; },
    clickScreen,
    clickWorld(x, y, z) { renderNow(); const s = toScreen([x, y, z]); return clickScreen(s[0], s[1]); },
    toScreen,
    setMeasuring,
    clearSelection,
    setView(mode) { setMode(mode === 'top' ? 'top' : 'perspective', true); renderNow(); },
    lookAt(x, y, z, extent) { flyTo(new THREE.Vector3(x, y, z).sub(center), extent, true); renderNow(); },
    setClassVisible(id, on) { setClassVisible(id, on); renderNow(); },
    setClip(z) { setClip(z); renderNow(); },
    setDetail(f) { state.detail = Math.max(0.001, Math.min(1, f)); applyDetail(); renderNow(); },
    drawnPoints() { return groups.reduce((a, g) => a + (g.visible ? g.drawn : 0), 0); },
    countPixels,
    renderNow,
    live,
  };
})();
