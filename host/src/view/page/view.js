// Strahl's live view: draws the server-sent events of /events (see docs/view.md) on the canvas,
// fills the figures and the worker table, and for `strahl view` the settings form.
'use strict';

// The page's state; tests read it (window.strahl).
const S = {
  run: 0, width: 0, height: 0,
  top: 0,             // the image line of the canvas's first row (--region's top)
  image: null,        // ImageData: the 8-bit pixels as the image file has them
  authors: [],        // worker of each row (null: none yet, resumed, or the master's own)
  linesDrawn: 0,      // line events drawn in this run
  status: null, progress: null, workers: [], settings: null,
};
window.strahl = S;

const canvas = document.getElementById('image');
const ctx = canvas.getContext('2d');
const $ = (id) => document.getElementById(id);

// A colour per worker for the tint (golden-angle hues).
function workerColour(w) {
  const h = (w * 137.508) % 360, s = 0.75, l = 0.5;
  const k = (n) => (n + h / 30) % 12;
  const a = s * Math.min(l, 1 - l);
  const f = (n) => l - a * Math.max(-1, Math.min(k(n) - 3, Math.min(9 - k(n), 1)));
  return [f(0) * 255, f(8) * 255, f(4) * 255];
}

function decode(b64) {
  const bin = atob(b64);
  const out = new Uint8Array(bin.length);
  for (let i = 0; i < bin.length; i++) out[i] = bin.charCodeAt(i);
  return out;
}

// Draws canvas row y from S.image, tinted by its worker when the toggle is on.
function drawLine(y) {
  const w = S.width;
  const row = ctx.createImageData(w, 1);
  row.data.set(S.image.data.subarray(y * w * 4, (y + 1) * w * 4));
  const author = S.authors[y];
  if ($('tint').checked && author !== null && author !== undefined) {
    const c = workerColour(author);
    for (let i = 0; i < w * 4; i += 4) {
      for (let k = 0; k < 3; k++) row.data[i + k] = (row.data[i + k] + c[k]) / 2;
    }
  }
  ctx.putImageData(row, 0, y);
}

function redraw() {
  if (!S.image) return;
  for (let y = 0; y < S.height; y++) if (S.authors[y] !== undefined) drawLine(y);
}

function begin(d) {
  S.run = d.run; S.width = d.width; S.height = d.height; S.top = d.top; S.linesDrawn = 0;
  canvas.width = d.width; canvas.height = d.height;
  S.image = ctx.createImageData(d.width, d.height);
  for (let i = 3; i < S.image.data.length; i += 4) S.image.data[i] = 255;
  S.authors = new Array(d.height);
  ctx.putImageData(S.image, 0, 0);
}

function line(d) {
  const y = d.y - S.top;
  if (!S.image || y < 0 || y >= S.height) return;
  const rgb = decode(d.rgb);
  const px = S.image.data;
  for (let x = 0, o = y * S.width * 4; x < S.width; x++, o += 4) {
    px[o] = rgb[3 * x]; px[o + 1] = rgb[3 * x + 1]; px[o + 2] = rgb[3 * x + 2];
  }
  S.authors[y] = d.worker;
  S.linesDrawn++;
  drawLine(y);
}

function seconds(s) {
  if (s === null || s === undefined) return '–';
  if (s < 60) return s.toFixed(1) + ' s';
  return Math.floor(s / 60) + ' min ' + Math.round(s % 60) + ' s';
}

function rate(r) {
  if (r >= 1e6) return (r / 1e6).toFixed(2) + ' M';
  if (r >= 1e3) return (r / 1e3).toFixed(1) + ' k';
  return r.toFixed(0);
}

function progress(d) {
  S.progress = d;
  $('lines').textContent = d.done + ' / ' + d.total;
  $('bar-fill').style.width = (100 * d.done / Math.max(1, d.total)) + '%';
  $('rate').textContent = rate(d.rays_per_second);
  $('elapsed').textContent = seconds(d.seconds);
  $('left').textContent = d.done === d.total ? '0 s' : seconds(d.seconds_left);
  for (const kind of ['primary', 'extra_samples', 'shadow', 'reflection', 'refraction', 'occlusion']) {
    $('rays-' + kind).textContent = String(d.rays[kind]);
  }
}

function workers(rows) {
  S.workers = rows;
  const body = $('worker-rows');
  body.replaceChildren();
  rows.forEach((w, i) => {
    const tr = document.createElement('tr');
    if (w.state === 'lost') tr.className = 'lost';
    const c = workerColour(i).map(Math.round);
    const cells = ['', w.name + (w.name === w.address ? '' : ' (' + w.address + ')'), w.link,
      w.threads, w.lines, rate(w.rays_per_second), w.lost ? 'lost: ' + w.lost : w.state,
      w.reissued, w.dropped];
    cells.forEach((text, k) => {
      const td = document.createElement('td');
      td.textContent = String(text);
      if (k === 0) { td.className = 'swatch'; td.style.background = 'rgb(' + c.join(',') + ')'; }
      tr.appendChild(td);
    });
    body.appendChild(tr);
  });
}

const STATUS_WORDS = {
  idle: () => 'ready: set up the render and press Start',
  rendering: () => 'rendering',
  done: (d) => 'done: ' + d.output,
  stopped: (d) => 'stopped at ' + d.finished + ' of ' + d.total + ' lines; Resume goes on',
  failed: (d) => 'failed: ' + d.message,
};

function status(d) {
  S.status = d;
  const el = $('status');
  el.textContent = STATUS_WORDS[d.state](d);
  el.className = 'status ' + d.state;
  $('download').hidden = d.state !== 'done';
  $('stop').disabled = d.state !== 'rendering';
  $('resume').disabled = d.state !== 'stopped';
}

const FIELDS = ['width', 'height', 'multisample', 'max_depth', 'ambient_occlusion', 'workers'];

function settings(d) {
  S.settings = d;
  $('settings').hidden = false;
  for (const f of FIELDS) $(f).value = d[f];
  $('shadows').checked = d.shadows;
  $('reflections').checked = d.reflections;
  $('aa_threshold').value = d.aa_threshold === null ? '' : d.aa_threshold;
  $('tcp_workers').value = d.tcp_workers.join(', ');
}

function formSettings() {
  const d = {};
  for (const f of FIELDS) d[f] = Number($(f).value);
  d.shadows = $('shadows').checked;
  d.reflections = $('reflections').checked;
  const t = $('aa_threshold').value.trim();
  d.aa_threshold = t === '' ? null : Number(t);
  d.tcp_workers = $('tcp_workers').value.split(/[\s,]+/).filter((s) => s !== '');
  return d;
}

async function post(path, body) {
  $('form-error').textContent = '';
  const r = await fetch(path, {
    method: 'POST',
    headers: { 'Content-Type': 'application/json' },
    body: body === undefined ? '' : JSON.stringify(body),
  });
  if (!r.ok) $('form-error').textContent = (await r.text()).trim();
}

$('settings').addEventListener('submit', (e) => { e.preventDefault(); post('/api/start', formSettings()); });
$('stop').addEventListener('click', () => post('/api/stop'));
$('resume').addEventListener('click', () => post('/api/resume'));
$('tint').checked = location.hash === '#tint';
$('tint').addEventListener('change', redraw);

const events = new EventSource('/events');
const on = (name, f) => events.addEventListener(name, (e) => f(JSON.parse(e.data)));
on('begin', begin);
on('line', line);
on('progress', progress);
on('workers', workers);
on('status', status);
on('settings', settings);
events.addEventListener('error', () => {
  if (!S.status || S.status.state === 'rendering') $('status').textContent = 'reconnecting…';
});
