// vdbmap report: draws the page from its embedded data (report-data, made by
// tools/report/report_data.cpp). Plain DOM and SVG for the header, figures, plots and tables;
// three.js for the 3D view. When done, <html data-status> reads "ready" (or "error", with the
// errors in #report-errors); the browser test reads that and the data-* attributes below.
import * as THREE from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';

const data = JSON.parse(document.getElementById('report-data').textContent);
const app = document.getElementById('app');
const SVG_NS = 'http://www.w3.org/2000/svg';

function el(tag, attrs = {}, ...children) {
  const node = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs)) {
    if (k === 'text') node.textContent = v;
    else if (k.startsWith('data-')) node.setAttribute(k, v);
    else node[k] = v;
  }
  for (const c of children) if (c !== null && c !== undefined) node.append(c);
  return node;
}

function svgEl(tag, attrs = {}, text) {
  const node = document.createElementNS(SVG_NS, tag);
  for (const [k, v] of Object.entries(attrs)) node.setAttribute(k, v);
  if (text !== undefined) node.textContent = text;
  return node;
}

function decode(b64, Type) {
  const bin = atob(b64 || '');
  const bytes = new Uint8Array(bin.length);
  for (let i = 0; i < bin.length; ++i) bytes[i] = bin.charCodeAt(i);
  return new Type(bytes.buffer);
}

function formatValue(v) {
  if (v === null || v === undefined) return 'n/a';
  if (typeof v === 'boolean') return v ? 'yes' : 'no';
  if (typeof v === 'number') {
    if (Number.isInteger(v)) return String(v);
    return Math.abs(v) >= 1000 ? v.toFixed(0) : String(Number(v.toPrecision(4)));
  }
  return String(v);
}

// ---- header and figures ------------------------------------------------------------------------

function header() {
  const h = data.header || {};
  const versions = Object.entries(h.versions || {}).map(([k, v]) => `${k} ${v}`).join(', ');
  const lines = [
    ['command', h.command], ['run', h.run_command && h.run_command !== h.command ? h.run_command : null],
    ['source', data.source], ['versions', versions], ['machine', h.machine], ['written', h.generated],
  ];
  const prov = el('div', { className: 'provenance' });
  for (const [label, value] of lines) {
    if (!value) continue;
    prov.append(el('div', {}, `${label}: `, el('code', { text: value })));
  }
  app.append(el('h1', { text: data.title || 'vdbmap report' }), prov);
  if ((data.notes || []).length) {
    const ul = el('ul', { className: 'note' });
    for (const n of data.notes) ul.append(el('li', { text: n }));
    app.append(ul);
  }
  const figures = el('section', { className: 'figures', id: 'figures' });
  for (const f of data.figures || []) {
    figures.append(el('div', { className: 'figure', 'data-label': f.label, 'data-value': JSON.stringify(f.value) },
      el('div', { className: 'label', text: f.label }),
      el('div', { className: 'value', text: formatValue(f.value) + (f.unit && f.value !== null ? ' ' + f.unit : '') })));
  }
  app.append(figures);
}

// ---- plots -------------------------------------------------------------------------------------

function niceTicks(lo, hi, count = 5) {
  if (!(hi > lo)) { hi = lo + 1; }
  const raw = (hi - lo) / count;
  const mag = Math.pow(10, Math.floor(Math.log10(raw)));
  const step = [1, 2, 5, 10].map((m) => m * mag).find((s) => s >= raw) || 10 * mag;
  const ticks = [];
  for (let t = Math.ceil(lo / step) * step; t <= hi + step * 1e-9; t += step) ticks.push(Number(t.toPrecision(12)));
  return ticks;
}

const PALETTE = ['#1f77b4', '#ff7f0e', '#2ca02c', '#d62728', '#9467bd', '#8c564b', '#e377c2', '#7f7f7f'];
const W = 600, H = 270, M = { l: 58, r: 14, t: 26, b: 40 };

function axes(svg, p, x0, x1, y0, y1, xTicks, xLabels) {
  const sx = (x) => M.l + (x - x0) / (x1 - x0 || 1) * (W - M.l - M.r);
  const sy = (y) => H - M.b - (y - y0) / (y1 - y0 || 1) * (H - M.t - M.b);
  svg.append(svgEl('text', { x: M.l, y: 16, class: 'title' }, p.title));
  for (const t of niceTicks(y0, y1)) {
    svg.append(svgEl('line', { x1: M.l, x2: W - M.r, y1: sy(t), y2: sy(t), stroke: '#eee' }));
    svg.append(svgEl('text', { x: M.l - 6, y: sy(t) + 4, 'text-anchor': 'end' }, formatValue(t)));
  }
  if (xTicks) {
    for (const t of niceTicks(x0, x1, 6)) {
      svg.append(svgEl('line', { x1: sx(t), x2: sx(t), y1: H - M.b, y2: H - M.b + 4, stroke: '#888' }));
      svg.append(svgEl('text', { x: sx(t), y: H - M.b + 16, 'text-anchor': 'middle' }, formatValue(t)));
    }
  }
  svg.append(svgEl('line', { x1: M.l, x2: W - M.r, y1: H - M.b, y2: H - M.b, stroke: '#888' }));
  svg.append(svgEl('line', { x1: M.l, x2: M.l, y1: M.t, y2: H - M.b, stroke: '#888' }));
  if (p.x_label) svg.append(svgEl('text', { x: (M.l + W - M.r) / 2, y: H - 6, 'text-anchor': 'middle' }, p.x_label));
  if (p.y_label) {
    svg.append(svgEl('text', { x: 14, y: (M.t + H - M.b) / 2, 'text-anchor': 'middle',
                               transform: `rotate(-90 14 ${(M.t + H - M.b) / 2})` }, p.y_label));
  }
  return { sx, sy };
}

function finite(values) { return values.filter((v) => v !== null && Number.isFinite(v)); }

function xyPlot(p) {
  const xs = [], ys = [];
  for (const s of p.series) { xs.push(...finite(s.x)); ys.push(...finite(s.y)); }
  for (const m of p.marks || []) xs.push(m.x);
  const x0 = xs.length ? Math.min(...xs) : 0, x1 = xs.length ? Math.max(...xs) : 1;
  const y0 = Math.min(0, ...(ys.length ? ys : [0])), y1raw = ys.length ? Math.max(...ys) : 1;
  const y1 = y1raw > y0 ? y1raw * 1.05 : y0 + 1;
  const svg = svgEl('svg', { viewBox: `0 0 ${W} ${H}`, 'data-plot-id': p.id, 'data-kind': 'xy' });
  const { sx, sy } = axes(svg, p, x0, x1, y0, y1, true);
  for (const m of p.marks || []) {
    svg.append(svgEl('line', { x1: sx(m.x), x2: sx(m.x), y1: M.t, y2: H - M.b, stroke: '#e377c2',
                               'stroke-dasharray': '3 3', class: 'mark', 'data-x': m.x }));
  }
  p.series.forEach((s, i) => {
    const color = PALETTE[i % PALETTE.length];
    const ysFinite = finite(s.y);
    const g = svgEl('g', { class: 'series', 'data-series': s.name, 'data-n': ysFinite.length,
                           'data-last': ysFinite.length ? ysFinite[ysFinite.length - 1] : '',
                           'data-max': ysFinite.length ? Math.max(...ysFinite) : '' });
    if (s.style === 'points') {
      let d = '';
      s.x.forEach((x, k) => { if (s.y[k] !== null) d += `M${sx(x).toFixed(1)} ${sy(s.y[k]).toFixed(1)}h0.01`; });
      g.append(svgEl('path', { d, stroke: color, 'stroke-width': 3, 'stroke-linecap': 'round', fill: 'none' }));
    } else {
      const pts = [];
      s.x.forEach((x, k) => { if (s.y[k] !== null) pts.push(`${sx(x).toFixed(1)},${sy(s.y[k]).toFixed(1)}`); });
      g.append(svgEl('polyline', { points: pts.join(' '), fill: 'none', stroke: color, 'stroke-width': 1.5 }));
    }
    svg.append(g);
    if (p.series.length > 1) {
      svg.append(svgEl('text', { x: W - M.r - 4, y: M.t + 12 + 14 * i, 'text-anchor': 'end', fill: color }, s.name));
    }
  });
  if ((p.marks || []).length) {
    svg.append(svgEl('text', { x: W - M.r - 4, y: M.t + 12 + 14 * p.series.length, 'text-anchor': 'end', fill: '#e377c2' },
                     `dashed: ${p.marks[0].label} (${p.marks.length})`));
  }
  return svg;
}

function barPlot(p) {
  const values = [];
  for (const g of p.groups) values.push(...finite(g.values));
  const y0 = Math.min(0, ...values), y1 = values.length ? Math.max(...values, 0) * 1.1 || 1 : 1;
  const svg = svgEl('svg', { viewBox: `0 0 ${W} ${H}`, 'data-plot-id': p.id, 'data-kind': 'bars' });
  const { sy } = axes(svg, p, 0, 1, y0, y1, false);
  const slot = (W - M.l - M.r) / Math.max(1, p.categories.length);
  const barW = slot * 0.8 / Math.max(1, p.groups.length);
  p.categories.forEach((c, ci) => {
    svg.append(svgEl('text', { x: M.l + slot * (ci + 0.5), y: H - M.b + 16, 'text-anchor': 'middle' }, c));
    p.groups.forEach((g, gi) => {
      const v = g.values[ci];
      if (v === null || !Number.isFinite(v)) return;
      const x = M.l + slot * ci + slot * 0.1 + barW * gi;
      svg.append(svgEl('rect', { x, y: Math.min(sy(v), sy(0)), width: barW * 0.92, height: Math.abs(sy(0) - sy(v)),
                                 fill: PALETTE[gi % PALETTE.length], class: 'bar', 'data-group': g.name,
                                 'data-category': c, 'data-value': v }));
    });
  });
  p.groups.forEach((g, gi) => {
    svg.append(svgEl('text', { x: W - M.r - 4, y: M.t + 12 + 14 * gi, 'text-anchor': 'end',
                               fill: PALETTE[gi % PALETTE.length] }, g.name));
  });
  return svg;
}

function plots() {
  const list = [...(data.plots || [])];
  if (data.activity_time_s) {
    const names = Object.keys(data.activity_time_s);
    list.push({ id: 'activity', kind: 'bars', title: 'Simulated time per activity of the exploration manager',
                y_label: 's', categories: names.map((n) => n.replace('_', ' ')),
                groups: [{ name: 'time (s)', values: names.map((n) => data.activity_time_s[n]) }] });
  }
  if (!list.length) return;
  const box = el('section', { className: 'plots', id: 'plots' });
  for (const p of list) box.append(el('div', { className: 'plot' }, p.kind === 'bars' ? barPlot(p) : xyPlot(p)));
  app.append(el('h2', { text: 'Plots' }), box);
}

function tables() {
  for (const t of data.tables || []) {
    const table = el('table', { 'data-table-id': t.id });
    table.append(el('tr', {}, ...t.columns.map((c) => el('th', { text: c }))));
    for (const row of t.rows) table.append(el('tr', {}, ...row.map((v) => el('td', { text: formatValue(v) }))));
    app.append(el('h2', { text: t.title }), table);
    if (t.note) app.append(el('p', { className: 'note', text: t.note }));
  }
}

// ---- 3D view -----------------------------------------------------------------------------------

function view3d() {
  const sc = data.scene;
  if (!sc || (!sc.mesh && !(sc.lines || []).length)) return;
  app.append(el('h2', { text: '3D view' }));
  const canvas = el('canvas', { id: 'view3d' });
  const controlsBar = el('div', { className: 'controls' });
  const view = el('div', { className: 'view' }, canvas, controlsBar);
  if (sc.caption) view.append(el('div', { className: 'caption', text: sc.caption }));
  app.append(view);

  const renderer = new THREE.WebGLRenderer({ canvas, antialias: true, preserveDrawingBuffer: true });
  renderer.setPixelRatio(1);
  renderer.localClippingEnabled = true;
  const cut = new THREE.Plane(new THREE.Vector3(0, 0, -1), 0);  // keeps z <= constant
  renderer.setSize(canvas.clientWidth, canvas.clientHeight, false);
  const scene = new THREE.Scene();
  scene.background = new THREE.Color(0xffffff);
  const camera = new THREE.PerspectiveCamera(50, canvas.clientWidth / canvas.clientHeight, 0.05, 2000);
  camera.up.set(0, 0, 1);
  scene.add(new THREE.AmbientLight(0xffffff, 1.3));
  const sun = new THREE.DirectionalLight(0xffffff, 1.6);
  sun.position.set(0.4, -0.6, 1.0);
  scene.add(sun);

  const layers = [];  // {name, color, object, timed(t)}
  const bounds = new THREE.Box3();
  let meshBox = null;
  if (sc.mesh) {
    const g = new THREE.BufferGeometry();
    g.setAttribute('position', new THREE.BufferAttribute(decode(sc.mesh.positions, Float32Array), 3));
    g.setAttribute('color', new THREE.BufferAttribute(decode(sc.mesh.colors, Uint8Array), 3, true));
    g.setIndex(new THREE.BufferAttribute(decode(sc.mesh.indices, Uint32Array), 1));
    g.computeVertexNormals();
    g.computeBoundingBox();
    meshBox = g.boundingBox.clone();
    bounds.union(meshBox);
    const mesh = new THREE.Mesh(g, new THREE.MeshLambertMaterial({ vertexColors: true, side: THREE.DoubleSide,
                                                                   clippingPlanes: [cut] }));
    scene.add(mesh);
    layers.push({ name: `map mesh (${sc.mesh.triangles} triangles)`, color: '#999', object: mesh });
  }
  for (const l of sc.lines || []) {
    const xyz = decode(l.xyz, Float32Array), t = decode(l.t, Float32Array);
    const g = new THREE.BufferGeometry();
    g.setAttribute('position', new THREE.BufferAttribute(xyz, 3));
    g.computeBoundingBox();
    if (t.length) bounds.union(g.boundingBox);
    const line = new THREE.Line(g, new THREE.LineBasicMaterial({ color: l.color }));
    scene.add(line);
    layers.push({ name: l.name, color: l.color, object: line, visible: l.visible,
                  timed: (time) => { let n = 0; while (n < t.length && t[n] <= time) ++n; g.setDrawRange(0, n); } });
  }
  for (const s of sc.segments || []) {
    const xyz = decode(s.xyz, Float32Array), t = Array.from(decode(s.t, Float32Array));
    if (!t.length) continue;
    const order = t.map((_, i) => i).sort((a, b) => t[a] - t[b]);
    const sorted = new Float32Array(xyz.length);
    order.forEach((src, dst) => sorted.set(xyz.subarray(6 * src, 6 * src + 6), 6 * dst));
    const times = order.map((i) => t[i]);
    const g = new THREE.BufferGeometry();
    g.setAttribute('position', new THREE.BufferAttribute(sorted, 3));
    const lines = new THREE.LineSegments(g, new THREE.LineBasicMaterial({ color: s.color }));
    scene.add(lines);
    layers.push({ name: `${s.name} (${t.length})`, color: s.color, object: lines,
                  timed: (time) => { let n = 0; while (n < times.length && times[n] <= time) ++n; g.setDrawRange(0, 2 * n); } });
  }
  for (const p of sc.points || []) {
    if (!p.points.length) continue;
    const group = new THREE.Group();
    const geometry = new THREE.SphereGeometry(p.radius_m, 16, 12);
    const material = new THREE.MeshBasicMaterial({ color: p.color });
    for (const q of p.points) {
      const m = new THREE.Mesh(geometry, material);
      m.position.set(q.xyz[0], q.xyz[1], q.xyz[2]);
      m.userData.t = q.t;
      group.add(m);
    }
    scene.add(group);
    layers.push({ name: `${p.name} (${p.points.length})`, color: p.color, object: group,
                  timed: (time) => { for (const m of group.children) m.visible = m.userData.t <= time; } });
  }

  // Look at everything from the south-east, above.
  if (bounds.isEmpty()) bounds.set(new THREE.Vector3(-1, -1, 0), new THREE.Vector3(1, 1, 1));
  const center = bounds.getCenter(new THREE.Vector3());
  const size = bounds.getSize(new THREE.Vector3());
  const reach = Math.max(size.x, size.y, size.z, 1);
  camera.position.set(center.x + 0.12 * reach, center.y - 0.42 * reach, center.z + 0.72 * reach);
  camera.near = reach / 1000;
  camera.far = reach * 20;
  camera.updateProjectionMatrix();
  const controls = new OrbitControls(camera, canvas);
  controls.target.copy(center);
  controls.update();
  const render = () => renderer.render(scene, camera);
  controls.addEventListener('change', render);
  window.addEventListener('resize', () => {
    renderer.setSize(canvas.clientWidth, canvas.clientHeight, false);
    camera.aspect = canvas.clientWidth / canvas.clientHeight;
    camera.updateProjectionMatrix();
    render();
  });

  for (const layer of layers) {
    const box = el('input', { type: 'checkbox', checked: layer.visible !== false });
    layer.object.visible = box.checked;
    box.addEventListener('change', () => { layer.object.visible = box.checked; render(); });
    controlsBar.append(el('label', { 'data-layer': layer.name }, box,
                          el('span', { className: 'swatch', style: `background:${layer.color}` }), layer.name));
  }
  if (sc.mesh && sc.mesh.legend) {
    const lg = sc.mesh.legend;
    const gradient = lg.stops.map((c) => `rgb(${c[0]},${c[1]},${c[2]})`).join(',');
    controlsBar.append(el('span', { className: 'legend' }, lg.label + ': ', formatValue(lg.min),
                          el('span', { className: 'bar', style: `background:linear-gradient(to right,${gradient})` }),
                          formatValue(lg.max) + '+'));
  }
  if (sc.mesh) {
    // A cut above a height opens the rooms to view (a ceiling would hide them); the default
    // removes the top eighth of the mesh's height.
    const z0 = meshBox.min.z, z1 = meshBox.max.z;
    const initial = z1 - 0.125 * (z1 - z0);
    const label = el('span');
    const slider = el('input', { type: 'range', min: z0, max: z1 + 1e-3, step: (z1 - z0) / 200 || 0.01, value: initial, id: 'cut-slider' });
    const apply = () => {
      cut.constant = Number(slider.value);
      label.textContent = `${formatValue(cut.constant)} m`;
    };
    slider.addEventListener('input', () => { apply(); render(); });
    apply();
    controlsBar.append(el('div', { className: 'slider' }, 'mesh below z', slider, label));
  }
  if (sc.t_max > 0) {
    const label = el('span', { text: `t = ${formatValue(sc.t_max)} s` });
    const slider = el('input', { type: 'range', min: 0, max: sc.t_max, step: sc.t_max / 1000, value: sc.t_max, id: 'time-slider' });
    slider.addEventListener('input', () => {
      const time = Number(slider.value);
      label.textContent = `t = ${formatValue(time)} s`;
      for (const layer of layers) if (layer.timed) layer.timed(time);
      render();
    });
    controlsBar.append(el('div', { className: 'slider' }, 'time', slider, label));
  }
  render();

  // What the test reads: how much of the canvas the first frame drew (not background).
  const gl = renderer.getContext();
  const w = gl.drawingBufferWidth, h = gl.drawingBufferHeight;
  const pixels = new Uint8Array(w * h * 4);
  gl.readPixels(0, 0, w, h, gl.RGBA, gl.UNSIGNED_BYTE, pixels);
  let drawn = 0;
  for (let i = 0; i < pixels.length; i += 4) if (pixels[i] < 250 || pixels[i + 1] < 250 || pixels[i + 2] < 250) ++drawn;
  canvas.dataset.drawnFraction = (drawn / (w * h)).toFixed(4);
  canvas.dataset.layers = layers.length;
  const rect = canvas.getBoundingClientRect();
  canvas.dataset.rect = [rect.left, rect.top + window.scrollY, rect.width, rect.height].map(Math.round).join(',');
}

try {
  header();
  view3d();
  plots();
  tables();
} catch (e) {
  reportError(e && e.stack || e);
}
if (!window.reportErrors.length) document.documentElement.dataset.status = 'ready';
