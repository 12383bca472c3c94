// Vergence workbench: static pages, no build step, no CDN. Every figure comes from the JSON API; these
// files only gather inputs, call the API and draw what it answers. No stereo algorithm lives here.
//
// common.js: what every page shares: the page registry and navigation, the API call and its errors,
// number formatting and the CLI line, SVG plots, and jobs (POST /api/jobs/{kind}, progress by
// server-sent events, cancel). Each page is static/pages/<id>.html (its markup, fetched once on its
// first visit) and static/pages/<id>.js (which calls registerPage).
"use strict";

// ---------------------------------------------------------------- pages and navigation
// The pages in the order of the navigation bar. A page whose system has not landed is not registered:
// its section keeps its placeholder ("coming as the systems land").
const PAGE_TITLES = {
  budget: "Display and budget",
  stereo: "2D + depth to stereo",
  stereospace: "StereoSpace browser",
  rigs: "Rig planner",
  specular: "Specular",
};
const PAGES = {};
const DEFAULT_PAGE = "budget";
const started = new Set();

// A page's script registers it: init() runs once, after its markup (pages/<id>.html) is in its section.
function registerPage(id, init) {
  if (!(id in PAGE_TITLES)) throw new Error(`unknown page ${id}`);
  PAGES[id] = { title: PAGE_TITLES[id], init };
}

async function loadFragment(id) {
  const section = document.querySelector(`section[data-page="${id}"]`);
  const response = await fetch(`/static/pages/${id}.html`);
  if (!response.ok) {
    throw new ApiError(`the page ${id} is not installed (static/pages/${id}.html: HTTP ${response.status})`);
  }
  section.innerHTML = await response.text();
  section.classList.remove("placeholder");
}

async function showPage() {
  const asked = location.hash.slice(1);
  const id = asked in PAGE_TITLES ? asked : DEFAULT_PAGE;
  for (const section of document.querySelectorAll("section.page")) section.hidden = section.dataset.page !== id;
  for (const link of document.querySelectorAll("[data-page-link]")) {
    link.classList.toggle("current", link.dataset.pageLink === id);
    link.classList.toggle("soon", !(link.dataset.pageLink in PAGES));
    if (link.dataset.pageLink === id) link.setAttribute("aria-current", "page");
    else link.removeAttribute("aria-current");
  }
  document.title = `${PAGE_TITLES[id]} · Vergence workbench`;
  showError(null);
  if (!(id in PAGES)) { document.body.dataset.state = "ready"; return; }
  if (started.has(id)) return;
  started.add(id);
  document.body.dataset.state = "loading";
  try {
    await loadFragment(id);
  } catch (exc) {
    started.delete(id);
    showError(exc.message);
    document.body.dataset.state = "error";
    return;
  }
  PAGES[id].init();
}

window.addEventListener("hashchange", showPage);
document.addEventListener("DOMContentLoaded", showPage);

// ---------------------------------------------------------------- kernels
// vergence serve compiles the pages' kernels in the background when it starts (the first time only; then
// they load from Numba's cache). While it does ("kernels": {state: "warming", done, total} in
// GET /api/health), a banner says how far it is, asked again every KERNEL_POLL_MS; then it goes away.
const KERNEL_POLL_MS = 1000;

async function watchKernels() {
  const banner = document.getElementById("kernels");
  let kernels = null;
  try { kernels = (await api("/api/health")).kernels; } catch (exc) { /* no server: nothing to show */ }
  if (!kernels || kernels.state !== "warming") { banner.hidden = true; return; }
  banner.textContent = `preparing kernels (first run only): ${kernels.done}/${kernels.total}`;
  banner.hidden = false;
  setTimeout(watchKernels, KERNEL_POLL_MS);
}

document.addEventListener("DOMContentLoaded", watchKernels);

// ---------------------------------------------------------------- API and messages
class ApiError extends Error {}

async function api(path, body) {
  let response;
  try {
    response = await fetch(path, body === undefined ? {} : {
      method: "POST", headers: { "Content-Type": "application/json" }, body: JSON.stringify(body),
    });
  } catch (exc) {
    throw new ApiError(`the workbench server does not answer (${path}): is vergence serve still running?`);
  }
  let data = null;
  try { data = await response.json(); } catch (exc) { /* not JSON: reported below */ }
  if (!response.ok) {
    const message = data && typeof data.error === "string" ? data.error
      : data && data.detail ? (typeof data.detail === "string" ? data.detail : JSON.stringify(data.detail))
      : `${path}: HTTP ${response.status}`;
    throw new ApiError(message);
  }
  if (data === null) throw new ApiError(`${path}: the answer is not JSON`);
  return data;
}

function showError(message) {
  const box = document.getElementById("error");
  box.textContent = message || "";
  box.hidden = !message;
}

function debounce(fn, ms) {
  let timer = null;
  return (...args) => { clearTimeout(timer); timer = setTimeout(() => fn(...args), ms); };
}

// ---------------------------------------------------------------- number formatting and the CLI line
function fmt(value, digits = 4) {
  if (value === null || value === undefined) return "—";
  if (!Number.isFinite(value)) return String(value);
  if (value === 0) return "0";
  const abs = Math.abs(value);
  return abs >= 1e5 || abs < 1e-3 ? value.toExponential(digits - 1) : String(Number(value.toPrecision(digits)));
}

function shellQuote(word) {
  return /^[A-Za-z0-9_.,=+\-\/:@]+$/.test(word) ? word : `'${word.replace(/'/g, `'\\''`)}'`;
}

function cliLine(command, body) {
  const words = ["vergence", command];
  for (const [key, value] of Object.entries(body)) {
    const option = "--" + key.replace(/_/g, "-");
    for (const item of Array.isArray(value) ? value : [value]) words.push(option, shellQuote(String(item)));
  }
  return words.join(" ");
}

// ---------------------------------------------------------------- SVG plots
const SVG_NS = "http://www.w3.org/2000/svg";
const PLOT = { width: 560, height: 260, left: 56, right: 14, top: 12, bottom: 38 };

function el(name, attrs = {}, text = null) {
  const node = document.createElementNS(SVG_NS, name);
  for (const [k, v] of Object.entries(attrs)) node.setAttribute(k, v);
  if (text !== null) node.textContent = text;
  return node;
}

function niceTicks(lo, hi, count = 5) {
  if (!(hi > lo)) { const pad = Math.abs(lo) * 0.1 || 1; lo -= pad; hi += pad; }
  const raw = (hi - lo) / count;
  const mag = 10 ** Math.floor(Math.log10(raw));
  const step = [1, 2, 2.5, 5, 10].map((m) => m * mag).find((s) => s >= raw);
  const ticks = [];
  for (let i = Math.ceil(lo / step); i * step <= hi + step * 1e-9; i++) {
    ticks.push(i === 0 ? 0 : Number((i * step).toPrecision(12)));
  }
  return { lo: Math.min(lo, ticks[0]), hi: Math.max(hi, ticks[ticks.length - 1]), ticks };
}

function logTicks(lo, hi) {
  const ticks = [];
  for (let e = Math.floor(Math.log10(lo)); e <= Math.ceil(Math.log10(hi)); e++) {
    for (const m of [1, 2, 5]) {
      const t = m * 10 ** e;
      if (t >= lo * (1 - 1e-9) && t <= hi * (1 + 1e-9)) ticks.push(t);
    }
  }
  return ticks;
}

// series: [{points: [[x, y|null], ...], cls, label}], x on a log axis when opts.xlog.
// A plot's axes: grid lines and labels at the ticks, the frame, the axis labels (PLOT's margins; its
// height given, as a histogram's SVG may be shorter).
function drawAxes(svg, xticks, yticks, tx, ty, height, opts) {
  const { width, left, right, top, bottom } = PLOT;
  const grid = el("g", { class: "axes" });
  for (const t of xticks) {
    grid.append(el("line", { x1: tx(t), x2: tx(t), y1: top, y2: height - bottom, class: "grid" }));
    grid.append(el("text", { x: tx(t), y: height - bottom + 14, "text-anchor": "middle" }, fmt(t, 3)));
  }
  for (const t of yticks) {
    grid.append(el("line", { x1: left, x2: width - right, y1: ty(t), y2: ty(t), class: "grid" }));
    grid.append(el("text", { x: left - 6, y: ty(t) + 4, "text-anchor": "end" }, fmt(t, 3)));
  }
  grid.append(el("rect", { x: left, y: top, width: width - left - right, height: height - top - bottom,
    class: "frame" }));
  grid.append(el("text", { x: (left + width - right) / 2, y: height - 6, "text-anchor": "middle", class: "label" },
    opts.xlabel));
  grid.append(el("text", { x: 12, y: (top + height - bottom) / 2, "text-anchor": "middle", class: "label",
    transform: `rotate(-90 12 ${(top + height - bottom) / 2})` }, opts.ylabel));
  svg.append(grid);
}

function drawPlot(svg, series, opts) {
  svg.replaceChildren();
  const { width, height, left, right, top, bottom } = PLOT;
  const xs = [], ys = [];
  for (const s of series) for (const [x, y] of s.points) {
    if (Number.isFinite(x) && (!opts.xlog || x > 0)) xs.push(x);
    if (Number.isFinite(y) && (s.unclipped || !opts.yclip || (y >= opts.yclip[0] && y <= opts.yclip[1]))) ys.push(y);
  }
  if (!xs.length || !ys.length) {
    svg.append(el("text", { x: width / 2, y: height / 2, class: "empty", "text-anchor": "middle" },
      opts.empty || "no data"));
    svg.dataset.points = "0";
    return;
  }
  let [xlo, xhi] = opts.xrange || [Math.min(...xs), Math.max(...xs)];
  const yr = niceTicks(Math.min(...ys, ...(opts.yinclude || [])), Math.max(...ys, ...(opts.yinclude || [])));
  const xt = opts.xlog ? null : niceTicks(xlo, xhi);
  if (xt) { xlo = xt.lo; xhi = xt.hi; }
  const tx = opts.xlog
    ? (x) => left + (Math.log(x) - Math.log(xlo)) / (Math.log(xhi) - Math.log(xlo) || 1) * (width - left - right)
    : (x) => left + (x - xlo) / (xhi - xlo || 1) * (width - left - right);
  const ty = (y) => top + (yr.hi - y) / (yr.hi - yr.lo || 1) * (height - top - bottom);

  if (opts.shade) {  // the divergence limit: eyes diverge from shade.from on
    const x0 = Math.max(left, tx(Math.max(opts.shade.from, xlo)));
    svg.append(el("rect", { x: x0, y: top, width: Math.max(0, width - right - x0), height: height - top - bottom,
      class: "shade" }));
    svg.append(el("text", { x: x0 + 4, y: top + 12, class: "shade-label" }, opts.shade.label));
  }
  drawAxes(svg, opts.xlog ? logTicks(xlo, xhi) : xt.ticks, yr.ticks, tx, ty, height, opts);
  for (const v of opts.vlines || []) {
    if (!(v.x >= xlo && v.x <= xhi)) continue;
    svg.append(el("line", { x1: tx(v.x), x2: tx(v.x), y1: top, y2: height - bottom, class: `vline ${v.cls || ""}` }));
    svg.append(el("text", { x: tx(v.x) + 3, y: height - bottom - 4, class: "vline-label" }, v.label));
  }
  // Curves leave the frame where they run off (z' and roundness blow up where the eyes turn parallel).
  const clipId = `${svg.id}-clip`;
  const defs = el("defs");
  const clip = el("clipPath", { id: clipId });
  clip.append(el("rect", { x: left, y: top, width: width - left - right, height: height - top - bottom }));
  defs.append(clip);
  svg.append(defs);
  const curves = el("g", { "clip-path": `url(#${clipId})` });
  svg.append(curves);
  let count = 0;
  for (const s of series) {
    let d = "", pen = false;
    for (const [x, y] of s.points) {
      const ok = Number.isFinite(x) && Number.isFinite(y) && (!opts.xlog || x > 0) && x >= xlo && x <= xhi;
      if (!ok) { pen = false; continue; }
      d += `${pen ? "L" : "M"}${tx(x).toFixed(2)},${ty(y).toFixed(2)}`;
      pen = true; count++;
    }
    if (d) curves.append(el("path", { d, class: `series ${s.cls}`, "data-series": s.label }));
    for (const [x, y] of s.dots || []) {
      if (Number.isFinite(x) && Number.isFinite(y)) {
        curves.append(el("circle", { cx: tx(x), cy: ty(y), r: 4, class: `dot ${s.cls}` }));
      }
    }
  }
  svg.dataset.points = String(count);
}

// ---------------------------------------------------------------- jobs
// Long work runs as a job on the server (POST /api/jobs/{kind}); its progress comes as server-sent events
// (GET /api/jobs/{id}/events) and DELETE /api/jobs/{id} cancels it. runJob resolves with the final
// status ({state: done|failed|cancelled, result, files, ...}); onProgress(status) sees each change and
// onStart(id) the job's id (from then on, cancelJob(id) means something). A refused request throws ApiError.
async function runJob(kind, body, { onProgress = () => {}, onStart = () => {} } = {}) {
  const job = await api(`/api/jobs/${kind}`, body);
  onStart(job.id);
  onProgress(job);
  if (["done", "failed", "cancelled"].includes(job.state)) return { ...job, cached: job.cached };
  await new Promise((resolve) => {
    const events = new EventSource(`/api/jobs/${job.id}/events`);
    events.addEventListener("progress", (ev) => onProgress(JSON.parse(ev.data)));
    events.addEventListener("end", () => { events.close(); resolve(); });
    events.onerror = () => { events.close(); resolve(); };
  });
  const status = await api(`/api/jobs/${job.id}`);
  return { ...status, cached: job.cached };
}

async function cancelJob(id) {
  try { await fetch(`/api/jobs/${id}`, { method: "DELETE" }); } catch (exc) { /* the event stream reports it */ }
}

// After runJob: whether the job is done. If not, says so: "cancelled" in the message element (the page is
// ready again), or the job's one-line error in the error box (the page is in error).
function jobDone(status, message) {
  if (status.state === "done") return true;
  message.textContent = status.state === "cancelled" ? "cancelled" : "";
  if (status.state === "failed") showError(status.error);
  document.body.dataset.state = status.state === "cancelled" ? "ready" : "error";
  return false;
}

// The URL of a done job's file.
function jobFile(id, name) { return `/api/jobs/${id}/files/${encodeURIComponent(name)}`; }

// ---------------------------------------------------------------- histograms
// bars: [{lo, hi, value}] drawn as SVG rectangles on a fixed x range (opts.xrange), each with data-lo,
// data-hi and data-value; opts.bands: [{from, to, cls, label}] shaded spans; opts.vlines as drawPlot's.
// The plot's layout is drawPlot's (PLOT), its height the svg's viewBox height.
function drawHistogram(svg, bars, opts) {
  svg.replaceChildren();
  const { width, left, right, top, bottom } = PLOT;
  const height = svg.viewBox.baseVal && svg.viewBox.baseVal.height ? svg.viewBox.baseVal.height : PLOT.height;
  const [xlo, xhi] = opts.xrange;
  const ymax = Math.max(...bars.map((b) => b.value), ...(opts.yinclude || [0]));
  const yr = niceTicks(0, ymax > 0 ? ymax : 1, 4);
  const tx = (x) => left + (x - xlo) / (xhi - xlo || 1) * (width - left - right);
  const ty = (y) => top + (yr.hi - y) / (yr.hi - yr.lo || 1) * (height - top - bottom);
  const clamp = (x) => Math.max(left, Math.min(width - right, tx(x)));
  const labels = [];
  for (const band of opts.bands || []) {
    const x0 = clamp(band.from), x1 = clamp(band.to);
    if (x1 > x0) svg.append(el("rect", { x: x0, y: top, width: x1 - x0, height: height - top - bottom,
      class: band.cls || "shade" }));
    // a narrow band at the right edge is labelled left of its start
    const outside = x1 - x0 < 80 && x1 >= width - right - 1;
    if (band.label && x1 > x0) labels.push(el("text", { x: outside ? x0 - 3 : x0 + 3, y: top + 11 + 13 * labels.length,
      "text-anchor": outside ? "end" : "start", class: "shade-label halo" }, band.label));
  }
  drawAxes(svg, niceTicks(xlo, xhi, 8).ticks.filter((t) => t >= xlo && t <= xhi), yr.ticks, tx, ty, height, opts);
  const g = el("g", { class: "bars" });
  for (const b of bars) {
    const x0 = clamp(b.lo), x1 = clamp(b.hi);
    g.append(el("rect", { x: x0, y: ty(b.value), width: Math.max(0, x1 - x0), height: ty(0) - ty(b.value),
      class: `bar ${b.cls || ""}`, "data-lo": String(b.lo), "data-hi": String(b.hi), "data-value": String(b.value) }));
  }
  svg.append(g);
  for (const v of opts.vlines || []) {
    if (!(v.x >= xlo && v.x <= xhi)) continue;
    svg.append(el("line", { x1: tx(v.x), x2: tx(v.x), y1: top, y2: height - bottom, class: `vline ${v.cls || ""}` }));
    svg.append(el("text", { x: tx(v.x) + 3, y: height - bottom - 4, class: "vline-label halo" }, v.label));
  }
  svg.append(...labels);  // over the bars
  svg.dataset.bars = String(bars.length);
}
