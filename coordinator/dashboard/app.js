// The dashboard's one script, for all three pages (body data-page = jobs, job or workers). It
// reads the JSON API with the session cookie, fills the page, and refreshes it every second. No
// library and nothing from the internet: the coordinator serves this file from its binary.
'use strict';

const REFRESH_MS = 1000;
let operator = false; // the session's role: only the operator (client token) may act

// ---- small helpers ------------------------------------------------------------------------------

function element(tag, attributes = {}, ...children) {
  const node = document.createElement(tag);
  for (const [name, value] of Object.entries(attributes)) {
    if (name === 'text') node.textContent = value;
    else node.setAttribute(name, value);
  }
  for (const child of children) node.append(child);
  return node;
}

function svgElement(tag, attributes = {}, text) {
  const node = document.createElementNS('http://www.w3.org/2000/svg', tag);
  for (const [name, value] of Object.entries(attributes)) node.setAttribute(name, value);
  if (text !== undefined) node.textContent = text;
  return node;
}

function showMessage(text) {
  document.getElementById('message').textContent = text || '';
}

function loginAgain() {
  location.href = '/dashboard/login?next=' + encodeURIComponent(location.pathname + location.search);
}

// GET of a JSON endpoint; a lapsed session goes back to the login form.
async function getJson(path) {
  const response = await fetch(path, {credentials: 'same-origin', cache: 'no-store'});
  if (response.status === 401) {
    loginAgain();
    throw new Error('not logged in');
  }
  if (!response.ok) throw new Error((await response.text()).trim());
  return response.json();
}

// One id per user action (128 random bits in hex), sent with a retry or delete: the coordinator
// records it with the change and answers a request carrying it again as it answered the first,
// so a repeated request (below, or across a coordinator restart) acts once.
function newRequestId() {
  const bytes = crypto.getRandomValues(new Uint8Array(16));
  return Array.from(bytes, (byte) => byte.toString(16).padStart(2, '0')).join('');
}

// The waits before an action with a request id is sent again, when the coordinator could not be
// reached or answered that it is unavailable (restarting).
const REPEAT_DELAYS_MS = [1000, 2000, 4000, 8000];
const UNAVAILABLE = [502, 503, 504];

// The buttons whose action is on its way: they stay disabled until it is answered, so that a
// double click sends one request.
const pendingButtons = new Set();

// An action (POST). The header tells the coordinator the request comes from its own pages: a
// page of another site cannot send it. With `requestId` the request is repeated (with that id)
// while the coordinator cannot be reached.
async function act(path, requestId) {
  const url = requestId ? `${path}&request_id=${requestId}` : path;
  let response;
  for (let attempt = 0; ; ++attempt) {
    try {
      response = await fetch(url, {
        method: 'POST',
        credentials: 'same-origin',
        headers: {'X-Alphorn-Dashboard': '1'},
      });
      if (!requestId || !UNAVAILABLE.includes(response.status)) break;
    } catch (error) {
      response = undefined;
      if (!requestId) break;
    }
    if (attempt === REPEAT_DELAYS_MS.length) break;
    await new Promise((resolve) => setTimeout(resolve, REPEAT_DELAYS_MS[attempt]));
  }
  if (!response) {
    showMessage('the coordinator could not be reached');
    return false;
  }
  if (response.status === 401) loginAgain();
  showMessage(response.ok ? '' : (await response.text()).trim());
  return response.ok;
}

// Runs a button's action once at a time.
async function actFrom(button, path, requestId) {
  pendingButtons.add(button);
  document.getElementById(button).disabled = true;
  try {
    return await act(path, requestId);
  } finally {
    pendingButtons.delete(button);
  }
}

function duration(seconds) {
  if (seconds === undefined || seconds === null || seconds < 0) return '–';
  if (seconds < 60) return seconds.toFixed(seconds < 10 ? 1 : 0) + ' s';
  const minutes = Math.floor(seconds / 60);
  if (minutes < 60) return minutes + ' min ' + Math.floor(seconds % 60) + ' s';
  return Math.floor(minutes / 60) + ' h ' + (minutes % 60) + ' min';
}

function clockTime(unixSeconds) {
  if (!unixSeconds) return '–';
  const date = new Date(unixSeconds * 1000);
  const pad = (n) => String(n).padStart(2, '0');
  return `${date.getFullYear()}-${pad(date.getMonth() + 1)}-${pad(date.getDate())} ` +
         `${pad(date.getHours())}:${pad(date.getMinutes())}:${pad(date.getSeconds())}`;
}

function percent(fraction) {
  if (fraction === undefined || fraction === null) return '–';
  const value = fraction * 100;
  return (value >= 10 ? value.toFixed(1) : value >= 1 ? value.toFixed(2) : value.toPrecision(2)) + ' %';
}

function rate(perSecond) {
  if (!perSecond) return '–';
  for (const [scale, unit] of [[1e9, 'G'], [1e6, 'M'], [1e3, 'k']])
    if (perSecond >= scale) return (perSecond / scale).toFixed(2) + ' ' + unit;
  return perSecond.toFixed(0);
}

// The state shown for a job: running, paused, done, failed or cancelled.
function jobState(job) {
  if (job.state === 'JOB_STATE_RUNNING' && job.paused) return 'paused';
  return job.state.replace('JOB_STATE_', '').toLowerCase();
}

function workerState(worker) {
  const state = worker.state.replace('WORKER_STATE_', '').toLowerCase();
  return worker.draining && state === 'alive' ? 'draining' : state;
}

function progressBar(done, total) {
  const bar = element('span', {class: 'bar'});
  bar.append(element('span', {style: `width: ${total ? (100 * done / total).toFixed(1) : 0}%`}));
  return element('span', {}, bar, `${done}/${total}`);
}

function passesText(job) {
  return `${job.passes_done}/${job.settings.passes}`;
}

// ---- the jobs page ------------------------------------------------------------------------------

async function refreshJobs() {
  const {jobs} = await getJson('/api/jobs');
  const body = document.querySelector('#jobs tbody');
  body.replaceChildren(...jobs.map((job) => {
    const state = jobState(job);
    const row = element('tr', {'data-job': job.job_id},
        element('td', {class: 'number'}, element('a', {href: `/dashboard/job?id=${job.job_id}`, text: job.job_id})),
        element('td', {text: job.settings.name || '–'}),
        job.suspect
          ? element('td', {class: 'state failed', text: `${state} (suspect)`, title: job.suspect})
          : element('td', {class: `state ${state}`, text: state}),
        element('td', {class: 'number', text: job.settings.priority}),
        element('td', {}, progressBar(job.units_done, job.units_total)),
        element('td', {class: 'number', text: passesText(job)}),
        element('td', {class: 'number', text: state === 'running' ? duration(job.eta_seconds) : '–'}),
        element('td', {class: 'number', text: percent(job.error_estimate)}),
        element('td', {text: clockTime(job.submitted_at_unix_seconds)}),
        element('td', {text: job.settings.owner || '–'}));
    return row;
  }));
  document.getElementById('empty').hidden = jobs.length > 0;
}

// ---- the job page -------------------------------------------------------------------------------

const jobPage = {
  id: new URLSearchParams(location.search).get('id'),
  lastSequence: 0,
  previewUnits: -1,
  logRows: [],
};
const MAX_LOG_ROWS = 500;

function fact(list, name, value) {
  list.append(element('dt', {text: name}), element('dd', {text: value}));
}

function showFacts(job) {
  const list = document.getElementById('facts');
  const state = jobState(job);
  const facts = element('dl', {class: 'facts', id: 'facts'});
  fact(facts, 'State', state);
  fact(facts, 'Priority', String(job.settings.priority));
  fact(facts, 'Units', `${job.units_done}/${job.units_total} merged, ${job.units_leased} leased`);
  fact(facts, 'Passes', passesText(job));
  fact(facts, 'ETA', state === 'running' ? duration(job.eta_seconds) : '–');
  let error = percent(job.error_estimate);
  if (job.error_estimate !== undefined) error += ` at ${job.error_estimate_passes} passes`;
  if (job.settings.target_error !== undefined) error += ` (target ${percent(job.settings.target_error)})`;
  fact(facts, 'Error estimate', error);
  fact(facts, 'Samples/s', rate(job.samples_per_second));
  fact(facts, 'Image', `${job.width} × ${job.height}, seed ${job.settings.seed}`);
  fact(facts, 'Submitted', clockTime(job.submitted_at_unix_seconds));
  fact(facts, 'Owner', job.settings.owner || '–');
  fact(facts, 'Workers', String(job.active_workers));
  fact(facts, 'Failed attempts', String(job.attempts_failed));
  if (job.error) fact(facts, 'Error', job.error);
  if (job.suspect) fact(facts, 'Suspect', job.suspect);
  if (job.units_audited) fact(facts, 'Units audited', `${job.units_audited}` +
      (job.audits_waiting ? ` (${job.audits_waiting} waiting for a second render)` : ''));
  list.replaceWith(facts);
  facts.querySelector('dd').className = `state ${state}`;

  const running = job.state === 'JOB_STATE_RUNNING';
  const ended = job.state === 'JOB_STATE_FAILED' || job.state === 'JOB_STATE_CANCELLED';
  const enable = {
    pause: running && !job.paused, resume: running && job.paused, cancel: running,
    retry: ended, delete: true, 'set-priority': running,
  };
  for (const [id, allowed] of Object.entries(enable)) {
    const button = document.getElementById(id);
    button.disabled = !operator || !allowed || pendingButtons.has(id);
    button.title = operator ? '' : 'The viewer token may look but not act';
  }
  const priority = document.getElementById('priority');
  priority.disabled = !operator || !running;
  if (document.activeElement !== priority) priority.value = job.settings.priority;
}

// Reloads the preview when more units are merged than the image shown holds.
function showPreview(job) {
  const note = document.getElementById('preview-note');
  const image = document.getElementById('preview');
  if (job.state === 'JOB_STATE_FAILED' || job.state === 'JOB_STATE_CANCELLED') {
    note.textContent = 'The job has no image: ' + (job.error || jobState(job));
    return;
  }
  note.textContent = `${job.units_done} of ${job.units_total} units merged, ${job.passes_done} passes complete`;
  if (job.units_done === jobPage.previewUnits) return;
  jobPage.previewUnits = job.units_done;
  image.src = `/api/job/preview.png?id=${job.job_id}&units=${job.units_done}`;
}

// The convergence chart: estimated relative RMSE against passes, both on log scales, with the
// 1/sqrt(passes) line through the latest estimate and the target, if any.
function drawChart(history, job) {
  const svg = document.getElementById('chart');
  svg.replaceChildren();
  const width = 420, height = 260, left = 62, right = 14, top = 12, bottom = 44;
  const plotWidth = width - left - right, plotHeight = height - top - bottom;
  if (history.length === 0) {
    svg.append(svgElement('text', {x: width / 2, y: height / 2, 'text-anchor': 'middle'},
                          'No estimate yet: the first is made at 4 passes.'));
    return;
  }
  const target = job.settings.target_error;
  const maxPasses = Math.max(job.settings.passes, ...history.map((p) => p.passes), 4);
  const xMin = 1, xMax = 2 ** Math.ceil(Math.log2(maxPasses));
  const values = history.map((p) => p.relative_rmse).filter((v) => v > 0);
  if (target) values.push(target);
  let yLow = Math.floor(Math.log10(Math.min(...values)));
  let yHigh = Math.ceil(Math.log10(Math.max(...values)));
  if (yHigh <= yLow) yHigh = yLow + 1;
  const x = (passes) => left + plotWidth * Math.log2(passes / xMin) / Math.log2(xMax / xMin);
  const y = (value) => top + plotHeight * (1 - (Math.log10(value) - yLow) / (yHigh - yLow));

  const clip = svgElement('clipPath', {id: 'plot-area'});
  clip.append(svgElement('rect', {x: left, y: top, width: plotWidth, height: plotHeight}));
  svg.append(clip);
  // Ticks: powers of two along the passes, 1-2-5 per decade along the error.
  const xStep = Math.log2(xMax / xMin) > 10 ? 2 : 1;
  for (let e = 0; xMin * 2 ** e <= xMax; e += xStep) {
    const passes = xMin * 2 ** e, at = x(passes);
    svg.append(svgElement('line', {class: 'grid', x1: at, x2: at, y1: top, y2: top + plotHeight}));
    svg.append(svgElement('line', {class: 'axis', x1: at, x2: at, y1: top + plotHeight, y2: top + plotHeight + 4}));
    svg.append(svgElement('text', {x: at, y: top + plotHeight + 16, 'text-anchor': 'middle'}, String(passes)));
  }
  for (let decade = yLow; decade <= yHigh; ++decade) {
    for (const mantissa of [1, 2, 5]) {
      const value = mantissa * 10 ** decade;
      if (Math.log10(value) > yHigh + 1e-9) break;
      const at = y(value);
      svg.append(svgElement('line', {class: 'grid', x1: left, x2: left + plotWidth, y1: at, y2: at}));
      svg.append(svgElement('line', {class: 'axis', x1: left - 4, x2: left, y1: at, y2: at}));
      svg.append(svgElement('text', {x: left - 7, y: at + 4, 'text-anchor': 'end'}, `${+(value * 100).toPrecision(3)} %`));
    }
  }
  svg.append(svgElement('line', {class: 'axis', x1: left, x2: left, y1: top, y2: top + plotHeight}));
  svg.append(svgElement('line', {class: 'axis', x1: left, x2: left + plotWidth, y1: top + plotHeight, y2: top + plotHeight}));
  svg.append(svgElement('text', {x: left + plotWidth / 2, y: height - 6, 'text-anchor': 'middle'}, 'passes (log scale)'));
  svg.append(svgElement('text', {x: 12, y: top + plotHeight / 2, 'text-anchor': 'middle',
                                 transform: `rotate(-90 12 ${top + plotHeight / 2})`}, 'relative RMSE (log scale)'));

  // The lines stay inside the axes; the points (inside by the choice of the ranges) are drawn
  // whole, also at the edges.
  const plotted = svgElement('g', {'clip-path': 'url(#plot-area)'});
  const last = history[history.length - 1];
  if (last.relative_rmse > 0) {
    const through = (passes) => last.relative_rmse * Math.sqrt(last.passes / passes);
    plotted.append(svgElement('line', {class: 'reference', x1: x(xMin), y1: y(through(xMin)),
                                       x2: x(xMax), y2: y(through(xMax))}));
  }
  if (target) {
    plotted.append(svgElement('line', {class: 'target', x1: left, x2: left + plotWidth, y1: y(target), y2: y(target)}));
    plotted.append(svgElement('text', {x: left + plotWidth - 4, y: y(target) - 4, 'text-anchor': 'end'}, 'target'));
  }
  const points = history.filter((p) => p.relative_rmse > 0);
  plotted.append(svgElement('polyline', {class: 'series',
                                         points: points.map((p) => `${x(p.passes)},${y(p.relative_rmse)}`).join(' ')}));
  svg.append(plotted);
  for (const p of points) {
    const dot = svgElement('circle', {class: 'point', cx: x(p.passes), cy: y(p.relative_rmse), r: 3.5});
    dot.append(svgElement('title', {}, `${p.passes} passes: ${percent(p.relative_rmse)}`));
    svg.append(dot);
  }
}

function showLog(log) {
  for (const event of log.events) {
    jobPage.lastSequence = Math.max(jobPage.lastSequence, Number(event.sequence));
    jobPage.logRows.push(element('tr', {},
        element('td', {class: 'number', text: event.sequence}),
        element('td', {text: clockTime(event.time_unix_seconds)}),
        element('td', {text: event.kind.replace('JOB_EVENT_', '').toLowerCase().replaceAll('_', ' ')}),
        element('td', {class: 'number', text: event.worker_id !== '0' ? event.worker_id : ''}),
        element('td', {class: 'number', text: event.has_unit ? event.unit_index : ''}),
        element('td', {class: 'wrap', text: event.message})));
  }
  if (log.events.length === 0) return;
  jobPage.logRows = jobPage.logRows.slice(-MAX_LOG_ROWS);
  // Newest first.
  document.querySelector('#log tbody').replaceChildren(...[...jobPage.logRows].reverse());
  const dropped = Number(log.events_dropped);
  document.getElementById('dropped').textContent =
      dropped > 0 ? `(${dropped} events in the middle dropped to bound the log)` : '';
}

async function refreshJob() {
  const answer = await getJson(`/api/job?id=${encodeURIComponent(jobPage.id)}&after=${jobPage.lastSequence}`);
  const job = answer.job;
  document.title = `Alphorn farm: job ${job.job_id}`;
  document.getElementById('title').textContent =
      `Job ${job.job_id}` + (job.settings.name ? `: ${job.settings.name}` : '');
  showFacts(job);
  showPreview(job);
  drawChart(answer.history, job);
  showLog(answer.log);
}

function setUpJobActions() {
  const id = encodeURIComponent(jobPage.id);
  const simple = {pause: 'pause', resume: 'resume'};
  for (const [button, action] of Object.entries(simple))
    document.getElementById(button).addEventListener('click', () => actFrom(button, `/api/job/${action}?id=${id}`).then(refresh));
  document.getElementById('retry').addEventListener('click', () => {
    actFrom('retry', `/api/job/retry?id=${id}`, newRequestId()).then(refresh);
  });
  document.getElementById('cancel').addEventListener('click', () => {
    if (confirm(`Cancel job ${jobPage.id}? Its merged units stay; retry runs it again.`))
      act(`/api/job/cancel?id=${id}`).then(refresh);
  });
  document.getElementById('delete').addEventListener('click', async () => {
    if (!confirm(`Delete job ${jobPage.id} with its images and log (a running job is cancelled first)?`)) return;
    if (await actFrom('delete', `/api/job/delete?id=${id}`, newRequestId())) location.href = '/dashboard/';
  });
  document.getElementById('set-priority').addEventListener('click', () => {
    const priority = document.getElementById('priority').value;
    act(`/api/job/priority?id=${id}&priority=${encodeURIComponent(priority)}`).then(refresh);
  });
}

// ---- the workers page ---------------------------------------------------------------------------

async function refreshWorkers() {
  const answer = await getJson('/api/workers');
  const body = document.querySelector('#workers tbody');
  body.replaceChildren(...answer.workers.map((worker) => {
    const state = workerState(worker);
    const held = answer.held_units[worker.worker_id] || [];
    const units = held.length === 0 ? '–' : held.map((u) => `job ${u.job_id} unit ${u.unit_index}`).join(', ');
    const button = element('button', {type: 'button', class: worker.draining ? 'undrain' : 'drain',
                                      text: worker.draining ? 'Undrain' : 'Drain'});
    const gone = state === 'dead' || state === 'left';
    button.disabled = !operator || gone || worker.exiting;
    if (!operator) button.title = 'The viewer token may look but not act';
    button.addEventListener('click', () =>
      act(`/api/worker/${worker.draining ? 'undrain' : 'drain'}?id=${worker.worker_id}`).then(refresh));
    return element('tr', {'data-worker': worker.worker_id},
        element('td', {class: 'number', text: worker.worker_id}),
        element('td', {text: worker.name}),
        worker.quarantined
          ? element('td', {class: 'state quarantined', text: 'quarantined', title: worker.quarantined})
          : element('td', {class: `state ${state}`, text: state + (worker.exiting ? ' (exiting)' : '')}),
        element('td', {text: units}),
        element('td', {class: 'number', text: worker.units_merged}),
        element('td', {class: 'number', text: rate(worker.samples_per_second)}),
        element('td', {class: 'number', text: rate(worker.rays_per_second)}),
        element('td', {class: 'number', text: worker.cores}),
        element('td', {class: 'number', text: duration(worker.seconds_since_seen) + ' ago'}),
        element('td', {text: worker.version}),
        element('td', {class: 'fingerprint', text: worker.engine_fingerprint || '–'}),
        element('td', {}, button));
  }));
  document.getElementById('empty').hidden = answer.workers.length > 0;
}

// ---- every page ---------------------------------------------------------------------------------

const page = document.body.dataset.page;
const refreshers = {jobs: refreshJobs, job: refreshJob, workers: refreshWorkers};

async function refresh() {
  try {
    await refreshers[page]();
  } catch (error) {
    showMessage(error.message);
  }
}

async function start() {
  const here = {jobs: 'nav-jobs', job: 'nav-jobs', workers: 'nav-workers'}[page];
  document.getElementById(here).classList.add('here');
  document.getElementById('logout').addEventListener('click', async () => {
    await act('/dashboard/logout');
    location.href = '/dashboard/login';
  });
  try {
    const session = await getJson('/api/session');
    operator = session.role === 'operator';
    document.getElementById('role').textContent = operator ? 'operator' : 'viewer (read-only)';
  } catch (error) {
    showMessage(error.message);
  }
  if (page === 'job') setUpJobActions();
  await refresh();
  setInterval(refresh, REFRESH_MS);
}

start();
