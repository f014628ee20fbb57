// The plotter web app's page. It holds no pipeline logic: the server loads, lays out, orders, plans and plots;
// this script sends the user's choices, draws what the server returns, and shows its events.
'use strict';

const $ = (id) => document.getElementById(id);
const SVGNS = 'http://www.w3.org/2000/svg';
let token = sessionStorage.getItem('plotter-token');
let snap = null;          // the last state snapshot
let view = null;          // the prepared drawing (GET /api/view)
let viewVersion = -1;
let steppedVersion = null;
let ink = { paths: [], done: 0, partial: null };

function say(text, error) {
  const m = $('message');
  m.textContent = text || '';
  m.className = error ? 'error' : '';
}

async function api(path, body, raw) {
  const headers = {};
  if (token) headers['X-Plotter-Token'] = token;
  const init = { method: 'POST', headers };
  if (raw !== undefined) { init.body = raw; }
  else if (body !== undefined) { init.body = JSON.stringify(body); headers['Content-Type'] = 'application/json'; }
  const r = await fetch(path, init);
  let data = {};
  try { data = await r.json(); } catch (_) { /* empty answer */ }
  if (!r.ok) { say(data.error || (r.status + ' ' + r.statusText), true); throw new Error(data.error || r.status); }
  return data;
}

// ---- control -------------------------------------------------------------------------------------------------
let source = null;
async function claim() {
  try {
    const d = await api('/api/control/claim');
    token = d.token;
    sessionStorage.setItem('plotter-token', token);
  } catch (_) {
    token = null;
    sessionStorage.removeItem('plotter-token');
  }
  listen();
}

function listen() {
  if (source) source.close();
  source = new EventSource('/api/events' + (token ? '?token=' + encodeURIComponent(token) : ''));
  source.addEventListener('state', (e) => onState(JSON.parse(e.data)));
  source.addEventListener('progress', (e) => onProgress(JSON.parse(e.data)));
  source.addEventListener('log', (e) => log(JSON.parse(e.data)));
  source.addEventListener('prompt', (e) => showPrompt(JSON.parse(e.data)));
  source.addEventListener('done', (e) => { const d = JSON.parse(e.data); say(d.message, !d.ok); });
  source.onerror = () => say('lost the server; retrying…', true);
}

$('take-control').onclick = claim;

// ---- state ---------------------------------------------------------------------------------------------------
function mine() { return !!token && snap && snap.controlled; }

function onState(s) {
  snap = s;
  const controller = mine();
  document.body.classList.toggle('readonly', !controller);
  $('control-status').textContent = controller ? 'you control the plotter'
    : (s.controlled ? 'read-only: another page controls the plotter' : 'read-only: nobody controls the plotter');
  $('take-control').hidden = controller || s.controlled;
  $('drawing-name').textContent = s.drawing ? s.drawing.name : 'no drawing loaded';
  const warnings = [].concat(s.drawing ? s.drawing.warnings : [], s.prepared ? s.prepared.warnings : [],
    s.prepare_error ? [s.prepare_error] : []);
  $('warnings').replaceChildren(...warnings.map((w) => Object.assign(document.createElement('li'), { textContent: w })));
  fillSettings(s.settings);
  fillLayers(s);
  fillStats(s);
  fillMachine(s);
  fillPenSpeed(s);
  showPrompt(s.prompt);
  if (s.progress) onProgress(s.progress);
  if (s.view_version !== viewVersion) { viewVersion = s.view_version; loadView(); }
  if (s.stepped_version !== steppedVersion) { steppedVersion = s.stepped_version; loadStepped(); }
}

function fillSettings(st) {
  const set = (id, v) => { const el = $(id); if (document.activeElement !== el) el[el.type === 'checkbox' ? 'checked' : 'value'] = v; };
  const paper = $('paper');
  if (st.paper && ![...paper.options].some((o) => o.value === st.paper)) paper.add(new Option(st.paper, st.paper));
  set('paper', st.paper); set('orientation', st.orientation); set('margin', st.margin); set('rotate', String(((st.rotate % 4) + 4) % 4));
  set('fit', st.fit); set('center', st.center); set('optimize', st.optimize); set('trace', st.trace);
  set('colors', st.colors);
  set('paper-width', st.paper_width); set('paper-height', st.paper_height); set('paper-unit', st.paper_unit);
  set('hatch', st.hatch_mm); set('cross-hatch', st.cross_hatch); set('hatch-tone', st.hatch_tone);
  set('hidden-lines', st.hidden_lines);
  showCustomPaper();
}
function showCustomPaper() { $('custom-paper').hidden = $('paper').value !== 'custom'; }

// The pen and speed sliders: what the page chose, else the profile's own values.
const SLIDERS = ['pen_up_pct', 'pen_down_pct', 'speed_pendown_pct', 'speed_penup_pct'];
const sliderId = (k) => k.replace(/_/g, '-');
function fillPenSpeed(s) {
  for (const k of SLIDERS) {
    const el = $(sliderId(k));
    const v = s.pen_speed[k] != null ? s.pen_speed[k] : s.pen_speed_profile[k];
    if (document.activeElement !== el && v != null) el.value = v;
    $(sliderId(k) + '-v').textContent = el.value + ' %';
  }
}
function sendPenSpeed() {
  const body = {};
  for (const k of SLIDERS) body[k] = Number($(sliderId(k)).value);
  api('/api/pen-speed', body).catch(() => {});
}
for (const k of SLIDERS) {
  const el = $(sliderId(k));
  el.oninput = () => { $(sliderId(k) + '-v').textContent = el.value + ' %'; };
  el.onchange = sendPenSpeed;
}

function fillLayers(s) {
  const body = $('layers').tBodies[0];
  const rows = (s.drawing ? s.drawing.layers : []).map((l) => {
    const chosen = s.settings.layers.find((c) => c.name === l.name) || {};
    const tr = document.createElement('tr');
    tr.dataset.name = l.name;
    tr.innerHTML = '<td><input type="checkbox" class="ctl vis"></td><td class="name"></td>' +
      '<td><input type="color" class="ctl color"></td><td><input type="number" class="ctl width" min="0.05" max="20" step="0.05"></td>';
    tr.querySelector('.vis').checked = chosen.visible !== false;
    tr.querySelector('.name').textContent = l.name + ' (' + l.paths + ' paths)';
    tr.querySelector('.color').value = chosen.color || l.color;
    tr.querySelector('.width').value = +(chosen.width_mm || l.width_mm).toFixed(3);
    tr.querySelectorAll('input').forEach((i) => { i.onchange = sendSettings; });
    return tr;
  });
  if (!body.contains(document.activeElement)) body.replaceChildren(...rows);
}

const fmtTime = (s) => { s = Math.max(0, s); const m = Math.floor(s / 60); return m + ':' + (s - 60 * m).toFixed(1).padStart(4, '0'); };

function fillStats(s) {
  const items = [];
  if (s.prepared) {
    const st = s.prepared.stats;
    items.push(['paths', st.paths], ['pen down', st.pen_down_mm.toFixed(1) + ' mm'], ['pen up', st.pen_up_mm.toFixed(1) + ' mm']);
    if (s.prepared.pen_up_before_mm != null) items.push(['ordering', s.prepared.pen_up_before_mm.toFixed(1) + ' → ' + s.prepared.pen_up_after_mm.toFixed(1) + ' mm travel']);
    if (st.bbox_mm) items.push(['size', (st.bbox_mm[2] - st.bbox_mm[0]).toFixed(1) + ' × ' + (st.bbox_mm[3] - st.bbox_mm[1]).toFixed(1) + ' mm']);
    const on = s.prepared.estimate_for ? ' on ' + s.prepared.estimate_for : '';
    items.push(['estimated time', s.prepared.estimate_s != null ? fmtTime(s.prepared.estimate_s) + on : 'cannot plot']);
  }
  items.push(['profile', s.profile]);
  $('stats').replaceChildren(...items.flatMap(([k, v]) => {
    const dt = document.createElement('dt'); dt.textContent = k;
    const dd = document.createElement('dd'); dd.textContent = v;
    if (k === 'estimated time') dd.id = 'estimate';
    return [dt, dd];
  }));
}

function fillMachine(s) {
  const p = $('profile');
  if (document.activeElement !== p) {
    p.replaceChildren(...s.profiles.map((n) => new Option(n, n, false, n === s.profile)));
  }
  const m = s.machine;
  const plotting = m.activity === 'plotting' || m.activity === 'paused';
  // Text nodes: the connected name holds what the machine answered (an HP-GL plotter's identity).
  const activity = document.createElement('span');
  activity.id = 'activity';
  activity.textContent = m.activity;
  const where = document.createElement('span');
  where.id = 'machine-pos';
  where.textContent = m.connected && m.position_mm ? standing(m.position_mm, m.pen_down) : '';
  $('machine-status').replaceChildren((m.connected ? m.connected : 'not connected') + ' — ', activity,
    where.textContent ? ' — ' : '', where, m.motors_off ? ' — motors off' : '');
  $('test-pen').disabled = !m.connected || plotting;
  $('motors-off').disabled = !m.connected || plotting || !!m.hpgl;
  $('downloads').classList.toggle('disabled', !s.prepared);
  fillResumable(s, plotting);
  // An HP-GL plotter has no homing and no jogging.
  $('home').disabled = !!m.hpgl;
  document.querySelectorAll('.jog-btn').forEach((b) => { b.disabled = !!m.hpgl; });
  $('plot').disabled = !m.connected || plotting || !s.prepared;
  $('pause').disabled = $('pause-now').disabled = m.activity !== 'plotting';
  $('resume').disabled = !(s.prompt && s.prompt.kind === 'pause');
  $('cancel').disabled = !plotting;
  $('disconnect').disabled = !m.connected || plotting;
}

// An interrupted plot of this drawing on this machine (its journal in the state directory), offered to resume.
function fillResumable(s, plotting) {
  const row = $('resumable'), r = s.resumable;
  row.hidden = !r;
  if (!r) { row.replaceChildren(); return; }
  const b = document.createElement('button');
  b.id = 'resume-plot'; b.className = 'ctl'; b.textContent = 'Resume it';
  b.title = 'continue where it stopped, on the plotter it ran on (it homes first)';
  b.disabled = !s.machine.connected || !s.machine.journaled || plotting;
  b.onclick = () => api('/api/resume-plot').then(() => say('resuming the interrupted plot…')).catch(() => {});
  row.replaceChildren('The last plot of this drawing on this machine stopped at ' + Math.floor(r.percent) + ' %', b);
}

// ---- the drawing ---------------------------------------------------------------------------------------------
function polyline(points, attrs) {
  const el = document.createElementNS(SVGNS, 'polyline');
  el.setAttribute('points', points.map((p) => p[0] + ',' + p[1]).join(' '));
  for (const k in attrs) el.setAttribute(k, attrs[k]);
  return el;
}

function fitView(v) {
  const svg = $('preview'), paper = $('paper-rect');
  let [w, h] = v && v.page_mm ? v.page_mm : [0, 0];
  if (!w && v && v.bbox_mm) { w = v.bbox_mm[2] + 10; h = v.bbox_mm[3] + 10; }
  if (!w) { w = 210; h = 297; }
  paper.setAttribute('width', w); paper.setAttribute('height', h);
  const pad = Math.max(w, h) * 0.02;
  svg.setAttribute('viewBox', [-pad, -pad, w + 2 * pad, h + 2 * pad].join(' '));
}

async function loadView() {
  try {
    const r = await fetch('/api/view');
    view = r.ok ? await r.json() : null;
  } catch (_) { view = null; }
  fitView(view);
  const g = $('g-drawing'), t = $('g-travel');
  g.replaceChildren(); t.replaceChildren();
  ink = { paths: [], done: 0, partial: null };
  $('g-ink').replaceChildren();
  if (!view) return;
  for (const layer of view.layers) {
    for (const p of layer.paths) {
      g.appendChild(polyline(p.points, { stroke: layer.color, 'stroke-width': layer.width_mm }));
      ink.paths.push({ p, color: layer.color, width: layer.width_mm });
    }
  }
  for (const [a, b] of view.travel) {
    const l = document.createElementNS(SVGNS, 'line');
    l.setAttribute('x1', a[0]); l.setAttribute('y1', a[1]); l.setAttribute('x2', b[0]); l.setAttribute('y2', b[1]);
    t.appendChild(l);
  }
  showTravel();
}

async function loadStepped() {
  const g = $('g-stepped');
  g.replaceChildren();
  if (steppedVersion == null) return;
  const r = await fetch('/api/stepped');
  if (!r.ok) return;
  const v = await r.json();
  for (const layer of v.layers) for (const p of layer.paths) g.appendChild(polyline(p.points, {}));
  g.dataset.paths = g.childElementCount;
  showTravel();
}

function showTravel() {
  $('g-travel').style.display = $('show-travel').checked ? '' : 'none';
  $('g-stepped').style.display = $('show-stepped').checked ? '' : 'none';
}
$('show-travel').onchange = showTravel;
$('show-stepped').onchange = showTravel;

// Ink the drawing up to `mm` of pen-down length: whole paths once, the path under the pen partly.
function inkTo(mm) {
  const g = $('g-ink');
  if (mm < ink.done) { g.replaceChildren(); ink.done = 0; ink.partial = null; }
  let i = g.childElementCount - (ink.partial ? 1 : 0);
  if (ink.partial) { ink.partial.remove(); ink.partial = null; }
  while (i < ink.paths.length && ink.paths[i].p.start_mm + ink.paths[i].p.length_mm <= mm + 1e-6) {
    const q = ink.paths[i];
    g.appendChild(polyline(q.p.points, { stroke: q.color, 'stroke-width': q.width }));
    i++;
  }
  if (i < ink.paths.length && ink.paths[i].p.start_mm < mm) {
    const q = ink.paths[i], pts = q.p.points, out = [pts[0]];
    let left = mm - q.p.start_mm;
    for (let k = 1; k < pts.length && left > 0; k++) {
      const dx = pts[k][0] - pts[k - 1][0], dy = pts[k][1] - pts[k - 1][1], d = Math.hypot(dx, dy);
      if (d <= left) { out.push(pts[k]); left -= d; } else { const f = left / d; out.push([pts[k - 1][0] + f * dx, pts[k - 1][1] + f * dy]); left = 0; }
    }
    ink.partial = polyline(out, { stroke: q.color, 'stroke-width': q.width });
    g.appendChild(ink.partial);
  }
  ink.done = mm;
}

function onProgress(p) {
  $('progress-bar').style.width = p.percent.toFixed(1) + '%';
  $('percent').textContent = Math.floor(p.percent) + ' %';
  $('eta').textContent = 'ETA ' + fmtTime(p.eta_s) + (p.resends ? ', ' + p.resends + ' resends' : '');
  if (ink.paths.length) inkTo(p.draw_done_mm);
  showPen(p.pen_mm, p.pen_down);
  // The machine's position follows the plot, in millimetres from the home corner as outside a plot.
  const where = $('machine-pos');
  if (where && snap && snap.machine.activity !== 'idle') where.textContent = standing(p.machine_mm, p.pen_down);
}

// Where the machine stands, for people: millimetres from the home corner and the pen.
function standing([x, y], down) {
  return 'X ' + x.toFixed(1) + ' mm, Y ' + y.toFixed(1) + ' mm' + (down == null ? '' : down ? ', pen down' : ', pen up');
}

// The pen marker on the drawing (filled while the pen is down) and its position in the status bar.
function showPen([x, y], down) {
  const m = $('pen-marker');
  m.setAttribute('cx', x); m.setAttribute('cy', y);
  m.setAttribute('visibility', 'visible');
  m.classList.toggle('down', down);
  $('pen-pos').textContent = 'X ' + x.toFixed(1) + ' mm, Y ' + y.toFixed(1) + ' mm' + (down ? ', pen down' : ', pen up');
}

// ---- prompts -------------------------------------------------------------------------------------------------
function showPrompt(p) {
  const box = $('prompt');
  if (!p) { box.hidden = true; return; }
  box.hidden = false;
  box.dataset.kind = p.kind;
  $('prompt-text').textContent = p.message;
  $('prompt-choices').replaceChildren(...p.choices.map((c) => {
    const b = document.createElement('button');
    b.className = 'ctl'; b.textContent = c; b.dataset.choice = c;
    b.onclick = () => api('/api/prompt', { id: p.id, answer: c }).catch(() => {});
    return b;
  }));
}

// ---- console -------------------------------------------------------------------------------------------------
function log(l) {
  const c = $('console');
  const line = document.createElement('div');
  line.className = l.dir;
  line.textContent = (l.dir === 'out' ? '> ' : l.dir === 'in' ? '< ' : '') + l.text;
  c.appendChild(line);
  while (c.childElementCount > 500) c.firstChild.remove();
  c.scrollTop = c.scrollHeight;
}
$('console-form').onsubmit = (e) => {
  e.preventDefault();
  const line = $('console-line').value;
  if (line.trim()) api('/api/console', { line }).then(() => { $('console-line').value = ''; }).catch(() => {});
};

// ---- inputs --------------------------------------------------------------------------------------------------
async function upload(file) {
  if (snap && file.size > snap.max_upload) {
    say(file.name + ' is too large: uploads are limited to ' + (snap.max_upload / 1048576).toFixed(1) + ' MB', true);
    return;
  }
  say('loading ' + file.name + '…');
  try { await api('/api/drawing?name=' + encodeURIComponent(file.name), undefined, file); say(file.name + ' loaded'); } catch (_) { /* said */ }
}
$('file').onchange = (e) => { if (e.target.files[0]) upload(e.target.files[0]); e.target.value = ''; };
const drop = $('drop');
drop.ondragover = (e) => { e.preventDefault(); drop.classList.add('over'); };
drop.ondragleave = () => drop.classList.remove('over');
drop.ondrop = (e) => { e.preventDefault(); drop.classList.remove('over'); if (e.dataTransfer.files[0]) upload(e.dataTransfer.files[0]); };
document.body.ondragover = (e) => e.preventDefault();
document.body.ondrop = (e) => { e.preventDefault(); if (e.dataTransfer.files[0]) upload(e.dataTransfer.files[0]); };
$('gen-go').onclick = () => api('/api/gen', { spec: $('gen-spec').value }).then(() => say('generated')).catch(() => {});

function sendSettings() {
  const layers = [...$('layers').tBodies[0].rows].map((tr) => ({
    name: tr.dataset.name,
    visible: tr.querySelector('.vis').checked,
    color: tr.querySelector('.color').value,
    width_mm: Number(tr.querySelector('.width').value) || 0,
  }));
  api('/api/settings', {
    paper: $('paper').value, orientation: $('orientation').value, margin: Number($('margin').value) || 0,
    fit: $('fit').checked, center: $('center').checked, rotate: Number($('rotate').value),
    optimize: $('optimize').checked, trace: $('trace').value, colors: $('colors').value, layers,
    paper_width: Number($('paper-width').value) || 0, paper_height: Number($('paper-height').value) || 0,
    paper_unit: $('paper-unit').value, hatch_mm: Number($('hatch').value) || 0,
    cross_hatch: $('cross-hatch').checked, hatch_tone: $('hatch-tone').checked,
    hidden_lines: $('hidden-lines').checked,
  }).catch(() => {});
}
['paper', 'orientation', 'margin', 'rotate', 'fit', 'center', 'optimize', 'trace', 'colors', 'paper-width',
  'paper-height', 'paper-unit', 'hatch', 'cross-hatch', 'hatch-tone', 'hidden-lines'].forEach((id) => { $(id).onchange = sendSettings; });
$('paper').addEventListener('change', showCustomPaper);

$('profile').onchange = () => api('/api/profile', { name: $('profile').value }).catch(() => {});
$('profile-file').onchange = async (e) => {
  const f = e.target.files[0];
  if (f) await api('/api/profile/upload?name=' + encodeURIComponent(f.name), undefined, f).catch(() => {});
  e.target.value = '';
};
async function refreshPorts() {
  const r = await fetch('/api/ports');
  if (!r.ok) return;
  const { ports } = await r.json();
  const sel = $('target'), keep = sel.value;
  sel.replaceChildren(new Option('built-in simulator', 'sim'), ...ports.map((p) => new Option(p, p)));
  sel.value = [...sel.options].some((o) => o.value === keep) ? keep : 'sim';
}
$('refresh-ports').onclick = refreshPorts;
// ---- HP-GL plotters: device, sheet and handshake, offered from the server's device table (GET /api/hpgl) --------
let hpgl = null;
const HANDSHAKE_LABELS = { escb: 'ESC.B queries (any cable)', xonxoff: 'Xon/Xoff', hardware: 'RTS/CTS lines' };
async function loadHpgl() {
  const r = await fetch('/api/hpgl');
  if (!r.ok) return;
  hpgl = await r.json();
  $('hpgl-device').replaceChildren(...hpgl.devices.map((d) =>
    new Option(d.name + ' (' + d.pens + ' pens)', d.id, false, d.id === hpgl.default_device)));
  $('handshake').replaceChildren(...hpgl.handshakes.map((h) =>
    new Option(HANDSHAKE_LABELS[h] || h, h, false, h === hpgl.default_handshake)));
  fillHpglPapers();
  showHpgl();
}
function fillHpglPapers() {
  const d = hpgl && hpgl.devices.find((x) => x.id === $('hpgl-device').value);
  if (!d) return;
  const mm = (v) => Math.round(v * 10) / 10;
  // The empty value lets the server take the first sheet that holds the drawing.
  const options = d.papers.length === 0 ? [new Option("the drawing's page", '')]
    : [new Option('sheet: the first that fits', ''),
      ...d.papers.map((p) => new Option(p.name + ' (' + mm(p.area_mm[0]) + ' × ' + mm(p.area_mm[1]) + ' mm)', p.name))];
  $('hpgl-paper').replaceChildren(...options);
}
function showHpgl() { $('hpgl-row').hidden = $('firmware').value !== 'hpgl'; }
$('firmware').onchange = showHpgl;
$('hpgl-device').onchange = fillHpglPapers;
function connectBody() {
  const body = { target: $('target').value, firmware: $('firmware').value };
  if (body.firmware === 'hpgl') {
    body.hpgl_device = $('hpgl-device').value || undefined;
    body.hpgl_paper = $('hpgl-paper').value || undefined;
    body.handshake = $('handshake').value || undefined;
  }
  return body;
}
$('connect').onclick = () => api('/api/connect', connectBody()).catch(() => {});
$('disconnect').onclick = () => api('/api/disconnect').catch(() => {});
$('home').onclick = () => api('/api/home').catch(() => {});
$('pen-up').onclick = () => api('/api/pen', { down: false }).catch(() => {});
$('pen-down').onclick = () => api('/api/pen', { down: true }).catch(() => {});
$('test-pen').onclick = () => api('/api/test-pen').then(() => say('testing the pen…')).catch(() => {});
$('motors-off').onclick = () => api('/api/motors-off').then(() => say('motors off: the carriage can be pushed by hand')).catch(() => {});
// A download that fails says why on the page instead of saving the error as the file.
for (const a of document.querySelectorAll('#downloads a')) {
  a.onclick = async (e) => {
    e.preventDefault();
    const r = await fetch(a.href);
    if (!r.ok) { let d = {}; try { d = await r.json(); } catch (_) { /* none */ } say(d.error || r.statusText, true); return; }
    const name = (r.headers.get('Content-Disposition') || '').match(/filename="([^"]+)"/);
    const url = URL.createObjectURL(await r.blob());
    const save = Object.assign(document.createElement('a'), { href: url, download: name ? name[1] : 'drawing' });
    document.body.appendChild(save); save.click(); save.remove();
    setTimeout(() => URL.revokeObjectURL(url), 10000);
  };
}
document.querySelectorAll('.jog-btn').forEach((b) => {
  b.onclick = () => api('/api/jog', { axis: b.dataset.axis, mm: Number(b.dataset.dir) * Number($('jog-step').value) }).catch(() => {});
});
$('plot').onclick = () => {
  $('g-ink').replaceChildren(); ink.done = 0; ink.partial = null;
  api('/api/plot').then(() => say('plotting…')).catch(() => {});
};
$('pause').onclick = () => api('/api/pause', { now: false }).then(() => say('pausing at the next pen-up…')).catch(() => {});
$('pause-now').onclick = () => api('/api/pause', { now: true }).then(() => say('holding…')).catch(() => {});
$('resume').onclick = () => api('/api/resume').catch(() => {});
$('cancel').onclick = () => api('/api/cancel').then(() => say('cancelling…')).catch(() => {});

refreshPorts();
loadHpgl();
claim();
