// The studio page: every machine side by side and the job queue, from the server's `studio` events.
'use strict';

const $ = (id) => document.getElementById(id);

// Who this page is signed in as: 'operator', 'viewer', or 'open' (a server that asks for no token). A viewer
// sees no queueing or control buttons (the server refuses them too), only the emergency stops.
let role = 'open';
const operates = () => role !== 'viewer';

function say(text, error) {
  const m = $('message');
  m.textContent = text;
  m.className = error ? 'error' : '';
}

async function post(url, body, type) {
  const init = { method: 'POST' };
  if (body !== undefined) {
    init.body = body;
    init.headers = { 'content-type': type || 'application/json' };
  }
  const r = await fetch(url, init);
  const answer = await r.json().catch(() => ({}));
  if (!r.ok) {
    say(answer.error || r.statusText, true);
    throw new Error(answer.error || r.statusText);
  }
  return answer;
}

function hms(s) {
  if (s === null || s === undefined) return '–';
  s = Math.max(0, Math.round(s));
  const h = Math.floor(s / 3600), m = Math.floor((s % 3600) / 60), sec = s % 60;
  return (h ? h + ':' + String(m).padStart(2, '0') : m) + ':' + String(sec).padStart(2, '0');
}

function text(tag, content, cls) {
  const e = document.createElement(tag);
  e.textContent = content;
  if (cls) e.className = cls;
  return e;
}

function button(label, action, cls, title) {
  const b = text('button', label, cls);
  if (title) b.title = title;
  b.addEventListener('click', () => action().catch(() => {}));
  return b;
}

function machineCard(m) {
  const card = document.createElement('section');
  card.className = 'machine';
  card.dataset.name = m.name;
  card.appendChild(text('h2', m.name));
  const dl = document.createElement('dl');
  const row = (k, v, cls) => { dl.appendChild(text('dt', k)); dl.appendChild(text('dd', v, cls)); };
  row('State', m.state.replace('_', ' '), 'state');
  row('Port', m.connected || m.device);
  row('Job', m.job ? '#' + m.job + ' ' + (m.drawing || '') : '–', 'job');
  row('Progress', m.job ? m.percent.toFixed(1) + ' %' : '–', 'percent');
  if (m.copy) row('Copy', m.copy, 'copy');
  row('Remaining', m.job ? hms(m.remaining_s) : '–', 'remaining');
  row('Pen', m.pen_mm ? m.pen_mm[0].toFixed(1) + ', ' + m.pen_mm[1].toFixed(1) + ' mm ' + (m.pen_down ? 'down' : 'up') : '–', 'pen');
  if (m.last) row('Last', m.last);
  card.appendChild(dl);
  const bar = document.createElement('progress');
  bar.max = 100;
  bar.value = m.job ? m.percent : 0;
  card.appendChild(bar);
  if (m.error) card.appendChild(text('p', m.error, 'error'));
  const url = '/api/machines/' + encodeURIComponent(m.name) + '/';
  if (m.prompt) {
    // Parked at a pen change, a refill or a layer's pause: what to do, and the button that goes on once it is done.
    const ask = document.createElement('div');
    ask.className = 'prompt';
    ask.setAttribute('role', 'alert');
    ask.appendChild(text('p', m.prompt));
    if (operates()) ask.appendChild(button('Done: resume', () => post(url + 'resume'), 'resume', 'go on plotting'));
    card.appendChild(ask);
  }
  const controls = document.createElement('div');
  controls.className = 'row';
  if (operates()) {
    controls.appendChild(button('Pause', () => post(url + 'pause'), 'pause', 'pause at the next pen-up'));
    controls.appendChild(button('Resume', () => post(url + 'resume'), 'resume'));
    controls.appendChild(button('Stop', () => post(url + 'stop'), 'stop', 'end the job at the next pen-up'));
  }
  controls.appendChild(button('Emergency stop', () => post(url + 'estop'), 'estop', 'stop at once, pen up'));
  card.appendChild(controls);
  return card;
}

function jobRow(j) {
  const tr = document.createElement('tr');
  const last = j.history.length ? j.history[j.history.length - 1] : null;
  tr.appendChild(text('td', '#' + j.id));
  tr.appendChild(text('td', j.drawing + (j.args.length ? ' ' + j.args.join(' ') : '')));
  tr.appendChild(text('td', j.machine || 'any'));
  tr.appendChild(text('td', j.state));
  tr.appendChild(text('td', j.claimed_by || '–'));
  tr.appendChild(text('td', last && last.plot_s !== null ? hms(last.plot_s) : '–'));
  tr.appendChild(text('td', last && last.outcome ? last.outcome : ''));
  const td = document.createElement('td');
  const url = '/api/queue/' + j.id + '/';
  if (!operates()) { tr.appendChild(td); return tr; }
  if (['queued', 'plotting', 'paused', 'interrupted'].includes(j.state)) td.appendChild(button('Cancel', () => post(url + 'cancel')));
  if (['failed', 'cancelled'].includes(j.state)) td.appendChild(button('Retry', () => post(url + 'retry')));
  if (j.state === 'interrupted') td.appendChild(button('Paper in place: resume', () => post(url + 'confirm')));
  tr.appendChild(td);
  return tr;
}

function show(studio) {
  if (studio.error) { say(studio.error, true); return; }
  const machines = $('machines');
  machines.replaceChildren(...studio.machines.map(machineCard));
  const select = $('machine');
  const chosen = select.value;
  select.replaceChildren(text('option', 'first idle one that fits'), ...studio.machines.map((m) => text('option', m.name)));
  select.options[0].value = '';
  select.value = chosen;
  $('jobs').replaceChildren(...studio.jobs.map(jobRow));
}

function listen() {
  const source = new EventSource('/api/events');
  source.addEventListener('studio', (e) => {
    $('status').textContent = 'live';
    show(JSON.parse(e.data));
  });
  source.onerror = () => {
    $('status').textContent = 'reconnecting…';
    // A session that ended (signed out elsewhere, expired, server restarted): back to the sign-in page.
    fetch('/auth/me').then((r) => { if (r.status === 401) location.reload(); }).catch(() => {});
  };
}

async function whoAmI() {
  const r = await fetch('/auth/me').catch(() => null);
  if (!r || !r.ok) return;
  role = (await r.json()).role;
  $('who').textContent = 'signed in: ' + role;
  $('who').hidden = false;
  $('signout').hidden = false;
  $('add-panel').hidden = !operates();
}

$('stop-all').addEventListener('click', () => post('/api/stop-all').then(() => say('every machine stopped')).catch(() => {}));
$('signout').addEventListener('click', () => post('/auth/signout').then(() => location.reload()).catch(() => {}));
$('add').addEventListener('click', async () => {
  const file = $('file').files[0];
  if (!file) { say('pick a drawing first', true); return; }
  const flags = $('flags').value.trim().split(/\s+/).filter((w) => w);
  const q = new URLSearchParams({ name: file.name, args: JSON.stringify(flags) });
  if ($('machine').value) q.set('machine', $('machine').value);
  const r = await post('/api/queue?' + q, await file.arrayBuffer(), 'application/octet-stream').catch(() => null);
  if (r) say('queued as job ' + r.id);
});
whoAmI().finally(listen);
