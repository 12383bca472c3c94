// Vergence workbench: static page, no build step, no CDN. Every figure comes from the JSON API
// (POST /api/budget, POST /api/mapping, GET /api/displays); this file only gathers inputs, calls the
// API and draws what it answers as inline SVG. No stereo algorithm lives here.
"use strict";

// ---------------------------------------------------------------- pages and navigation
// One entry per page of the workbench. A page whose system has not landed has init: null and shows its
// placeholder ("coming as the systems land"); to bring one live, give it an init function that fills
// its <section data-page="..."> and calls only the API.
const PAGES = {
  budget: { title: "Display and budget", init: initBudget },
  stereo: { title: "2D + depth to stereo", init: null },
  stereospace: { title: "StereoSpace browser", init: null },
  rigs: { title: "Rig planner", init: null },
  specular: { title: "Specular", init: initSpecular },
};
const DEFAULT_PAGE = "budget";
const started = new Set();

function showPage() {
  const id = location.hash.slice(1) in PAGES ? location.hash.slice(1) : DEFAULT_PAGE;
  for (const section of document.querySelectorAll("section.page")) section.hidden = section.dataset.page !== id;
  for (const link of document.querySelectorAll("[data-page-link]")) {
    const page = PAGES[link.dataset.pageLink];
    link.classList.toggle("current", link.dataset.pageLink === id);
    link.classList.toggle("soon", !page.init);
    if (link.dataset.pageLink === id) link.setAttribute("aria-current", "page"); else link.removeAttribute("aria-current");
  }
  document.title = `${PAGES[id].title} · Vergence workbench`;
  showError(null);
  if (!PAGES[id].init) { document.body.dataset.state = "ready"; return; }
  if (!started.has(id)) { started.add(id); PAGES[id].init(); }
}

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
  for (let i = Math.ceil(lo / step); i * step <= hi + step * 1e-9; i++) ticks.push(i === 0 ? 0 : Number((i * step).toPrecision(12)));
  return { lo: Math.min(lo, ticks[0]), hi: Math.max(hi, ticks[ticks.length - 1]), ticks };
}

function logTicks(lo, hi) {
  const ticks = [];
  for (let e = Math.floor(Math.log10(lo)); e <= Math.ceil(Math.log10(hi)); e++) {
    for (const m of [1, 2, 5]) { const t = m * 10 ** e; if (t >= lo * (1 - 1e-9) && t <= hi * (1 + 1e-9)) ticks.push(t); }
  }
  return ticks;
}

// series: [{points: [[x, y|null], ...], cls, label}], x on a log axis when opts.xlog.
function drawPlot(svg, series, opts) {
  svg.replaceChildren();
  const { width, height, left, right, top, bottom } = PLOT;
  const xs = [], ys = [];
  for (const s of series) for (const [x, y] of s.points) {
    if (Number.isFinite(x) && (!opts.xlog || x > 0)) xs.push(x);
    if (Number.isFinite(y) && (!opts.yclip || (y >= opts.yclip[0] && y <= opts.yclip[1]))) ys.push(y);
  }
  if (!xs.length || !ys.length) {
    svg.append(el("text", { x: width / 2, y: height / 2, class: "empty", "text-anchor": "middle" }, opts.empty || "no data"));
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
    svg.append(el("rect", { x: x0, y: top, width: Math.max(0, width - right - x0), height: height - top - bottom, class: "shade" }));
    svg.append(el("text", { x: x0 + 4, y: top + 12, class: "shade-label" }, opts.shade.label));
  }
  const grid = el("g", { class: "axes" });
  for (const t of opts.xlog ? logTicks(xlo, xhi) : xt.ticks) {
    grid.append(el("line", { x1: tx(t), x2: tx(t), y1: top, y2: height - bottom, class: "grid" }));
    grid.append(el("text", { x: tx(t), y: height - bottom + 14, "text-anchor": "middle" }, fmt(t, 3)));
  }
  for (const t of yr.ticks) {
    grid.append(el("line", { x1: left, x2: width - right, y1: ty(t), y2: ty(t), class: "grid" }));
    grid.append(el("text", { x: left - 6, y: ty(t) + 4, "text-anchor": "end" }, fmt(t, 3)));
  }
  grid.append(el("rect", { x: left, y: top, width: width - left - right, height: height - top - bottom, class: "frame" }));
  grid.append(el("text", { x: (left + width - right) / 2, y: height - 6, "text-anchor": "middle", class: "label" }, opts.xlabel));
  grid.append(el("text", { x: 12, y: (top + height - bottom) / 2, "text-anchor": "middle", class: "label",
    transform: `rotate(-90 12 ${(top + height - bottom) / 2})` }, opts.ylabel));
  svg.append(grid);
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
      if (Number.isFinite(x) && Number.isFinite(y)) curves.append(el("circle", { cx: tx(x), cy: ty(y), r: 4, class: `dot ${s.cls}` }));
    }
  }
  svg.dataset.points = String(count);
}

// ---------------------------------------------------------------- page 1: display and budget
const DENSE_SAMPLES = 120;  // depths sent to /api/budget for the curves (log-spaced over the scene)
const DEBOUNCE_MS = 200;
// The plots' vertical ranges: z' up to 4 viewing distances, roundness in [-1, 3]; beyond, the curves
// leave the frame (they blow up where the eyes turn parallel). The figures above show exact values.
const PERCEIVED_CAP = 4;
const ROUNDNESS_CLIP = [-1, 3];

function initBudget() {
  const form = document.getElementById("budget-form");
  const preset = document.getElementById("display-preset");
  const lengthIds = ["eye-separation", "viewing-distance", "screen-width"];
  let presets = {};
  let sequence = 0;
  let updates = 0;

  const value = (id) => document.getElementById(id).value.trim();
  const number = (id) => { const v = value(id); return v === "" ? null : Number(v); };
  const windowMode = () => form.querySelector("input[name=window-mode]:checked").value;

  // The request body of /api/budget, fields named as the options of `vergence budget` (snake_case).
  function displayFields(withPixels) {
    const body = {};
    if (preset.value) {
      body.display = preset.value;
      const px = number("screen-pixels");
      if (withPixels && px !== null && px !== presets[preset.value].resolution) body.screen_pixels = px;
      return body;
    }
    for (const [id, key] of [["eye-separation", "eye_separation"], ["viewing-distance", "viewing_distance"],
                             ["screen-width", "screen_width"]]) {
      if (number(id) !== null) body[key] = number(id);
    }
    if (withPixels && number("screen-pixels") !== null) body.screen_pixels = number("screen-pixels");
    return body;
  }

  function rigFields() {
    const body = {};
    if (number("baseline") !== null) body.baseline = number("baseline");
    if (number("convergence") !== null) body.convergence = number("convergence");
    if (windowMode() === "window") {
      if (number("window") !== null) body.window = number("window");
    } else {
      if (number("focal-mm") !== null) body.focal_mm = number("focal-mm");
      if (number("sensor-mm") !== null) body.sensor_mm = number("sensor-mm");
    }
    return body;
  }

  function denseDepths() {
    const near = number("near"), far = number("far");
    if (!(near > 0 && far > near && Number.isFinite(far))) return [];
    const out = [];
    for (let i = 0; i < DENSE_SAMPLES; i++) out.push(Number((near * (far / near) ** (i / (DENSE_SAMPLES - 1))).toPrecision(6)));
    return out;
  }

  function constraints() {
    const out = [];
    for (const row of document.querySelectorAll("#constraints tr")) {
      const [z, p, r] = [...row.querySelectorAll("input")].map((i) => i.value.trim());
      if (z === "" || p === "") continue;  // an unfinished row is not sent
      out.push(`z=${z},perceived=${p}` + (r === "" ? "" : `,roundness=${r}`));
    }
    return out;
  }

  // The mapping's rig: `vergence mapping` takes --window; with a focal length and sensor the window is
  // W = H S / F (S0 §2), as `vergence budget` derives it.
  function mappingBody() {
    const rig = rigFields();
    const body = { reference_baseline: rig.baseline, convergence: rig.convergence };
    body.window = windowMode() === "window" ? rig.window
      : (rig.convergence !== undefined && rig.focal_mm && rig.sensor_mm !== undefined
        ? Number((rig.convergence * rig.sensor_mm / rig.focal_mm).toPrecision(12)) : undefined);
    for (const k of Object.keys(body)) if (body[k] === undefined) delete body[k];
    Object.assign(body, displayFields(false));
    body.constraint = constraints();
    if (number("near") !== null) body.near = number("near");
    if (number("far") !== null) body.far = number("far");
    return body;
  }

  function setFigure(testid, v, text) {
    const node = document.querySelector(`[data-testid="${testid}"]`);
    node.textContent = text !== undefined ? text : fmt(v);
    if (v === null || v === undefined) node.removeAttribute("data-value"); else node.dataset.value = String(v);
  }

  function showBudget(result, curves, probe, convergence) {
    const [atH, atProbe] = result.depths;
    const dense = curves.depths;
    setFigure("divergence-baseline", result.divergence_baseline, `${fmt(result.divergence_baseline)} m`);
    setFigure("roundness-baseline", result.roundness_baseline, `${fmt(result.roundness_baseline)} m`);
    setFigure("focal-ratio", result.focal_ratio);
    setFigure("roundness-at-convergence", atH.roundness);
    setFigure("perceived-at-probe", atProbe.perceived_depth,
      atProbe.perceived_depth === null ? (atProbe.diverges ? "— (eyes diverge)" : "∞") : `${fmt(atProbe.perceived_depth)} m`);
    setFigure("roundness-at-probe", atProbe.roundness);
    const firstDiverging = dense.find((s) => s.diverges);
    setFigure("divergence-depth", firstDiverging ? firstDiverging.depth : null,
      firstDiverging ? `from z ≈ ${fmt(firstDiverging.depth)} m (first sampled depth)` : "not in the scene's depths");
    const list = document.getElementById("warnings");
    list.replaceChildren(...result.warnings.map((w) => Object.assign(document.createElement("li"), { textContent: w, title: w })));
    return { dense, firstDiverging, probe, convergence, viewingDistance: number("viewing-distance") || 1 };
  }

  // A budget curve as [z, value] points, broken where the eyes start to diverge (the curve jumps there).
  function budgetPoints(samples, key) {
    const points = [];
    samples.forEach((s, i) => {
      if (i > 0 && samples[i - 1].diverges !== s.diverges) points.push([s.depth, null]);
      points.push([s.depth, s[key]]);
    });
    return points;
  }

  function drawAll(budget, mapping) {
    const { dense, firstDiverging, probe, convergence, viewingDistance } = budget;
    const shade = firstDiverging ? { from: firstDiverging.depth, label: "eyes diverge" } : null;
    const vlines = [{ x: convergence, label: "H", cls: "h" }, { x: probe, label: "z", cls: "probe" }];
    const xrange = dense.length ? [dense[0].depth, dense[dense.length - 1].depth] : null;
    const mapped = mapping ? mapping.samples.filter((s) => s.depth !== null) : [];
    const common = { xlog: true, xrange, shade, vlines, xlabel: "scene depth z (m)" };
    drawPlot(document.getElementById("plot-perceived"), [
      { points: budgetPoints(dense, "perceived_depth"), cls: "budget", label: "budget" },
      ...(mapping ? [{ points: mapped.map((s) => [s.depth, s.perceived_depth]), cls: "psi", label: "psi" }] : []),
    ], { ...common, ylabel: "z′ (m)", yclip: [0, PERCEIVED_CAP * viewingDistance] });
    drawPlot(document.getElementById("plot-roundness"), [
      { points: budgetPoints(dense, "roundness"), cls: "budget", label: "budget" },
      ...(mapping ? [{ points: mapped.map((s) => [s.depth, s.roundness]), cls: "psi", label: "psi" }] : []),
    ], { ...common, ylabel: "roundness ρ", yinclude: [0, 1], yclip: ROUNDNESS_CLIP });
    const psiSvg = document.getElementById("plot-psi");
    if (!mapping) {
      drawPlot(psiSvg, [], { empty: "add a constraint to build ψ" });
    } else {
      const ds = mapping.samples.map((s) => s.disparity);
      drawPlot(psiSvg, [
        { points: [[Math.min(...ds), Math.min(...ds)], [Math.max(...ds), Math.max(...ds)]], cls: "identity", label: "identity" },
        { points: mapping.samples.map((s) => [s.disparity, s.mapped]), cls: "psi", label: "psi",
          dots: mapping.control_points.map((c) => [c.disparity, c.value]) },
      ], { xlabel: "captured disparity d", ylabel: "ψ(d)" });
    }
    psiSvg.dataset.constraints = String(mapping ? constraints().length : 0);
  }

  async function update() {
    const mine = ++sequence;
    document.body.dataset.state = "loading";
    const probe = number("probe"), convergence = number("convergence");
    const readouts = [convergence, probe].filter((v) => v !== null);
    // The figures come from the request the CLI line makes (the rig, the display and the two readout
    // depths): the command prints exactly what the page shows. The curves come from a second request
    // with the dense depths only.
    const body = { ...rigFields(), ...displayFields(true), depth: readouts };
    const dense = denseDepths();
    document.getElementById("cli-budget").value = cliLine("budget", body);
    const psiBody = constraints().length ? mappingBody() : null;
    document.getElementById("cli-mapping-row").hidden = !psiBody;
    if (psiBody) document.getElementById("cli-mapping").value = cliLine("mapping", psiBody);
    try {
      if (readouts.length < 2) throw new ApiError("enter the convergence distance H and the depth z to look at");
      if (!dense.length) throw new ApiError("the scene's depths: enter 0 < nearest < farthest, both finite");
      const [budget, curves, mapping] = await Promise.all([
        api("/api/budget", body), api("/api/budget", { ...body, depth: dense }),
        psiBody ? api("/api/mapping", psiBody) : null]);
      if (mine !== sequence) return;  // a newer input is on its way
      drawAll(showBudget(budget, curves, probe, convergence), mapping);
      document.querySelector(".results").classList.remove("stale");
      showError(null);
      document.body.dataset.state = "ready";
    } catch (exc) {
      if (mine !== sequence) return;
      if (!(exc instanceof ApiError)) throw exc;
      document.querySelector(".results").classList.add("stale");
      showError(exc.message);
      document.body.dataset.state = "error";
    } finally {
      if (mine === sequence) document.body.dataset.updates = String(++updates);
    }
  }
  const debounced = debounce(update, DEBOUNCE_MS);
  // "pending" from the first keystroke to the answer of the last: "ready" or "error" mean the page
  // shows the API's answer to the inputs as they are now.
  // A new input also retires the request in flight (its answer is for the inputs as they were).
  const later = () => { sequence++; document.body.dataset.state = "pending"; debounced(); };

  function addConstraint(z, perceived, roundness) {
    const row = document.createElement("tr");
    const cells = [["z", z], ["perceived", perceived], ["roundness", roundness]].map(([name, v]) => {
      const td = document.createElement("td");
      const input = Object.assign(document.createElement("input"), { type: "number", step: "any", name, value: v ?? "" });
      input.setAttribute("aria-label", name);
      input.dataset.field = name;
      td.append(input);
      return td;
    });
    const remove = Object.assign(document.createElement("button"), { type: "button", textContent: "Remove", className: "remove" });
    remove.dataset.testid = "remove-constraint";
    remove.addEventListener("click", () => { row.remove(); later(); });
    const td = document.createElement("td");
    td.append(remove);
    row.append(...cells, td);
    document.getElementById("constraints").append(row);
  }

  document.getElementById("add-constraint").addEventListener("click", () => {
    // A new row starts where the budget is neutral: the convergence distance seen on the screen plane.
    addConstraint(value("convergence"), value("viewing-distance"), "1");
    later();
  });

  preset.addEventListener("change", () => {
    const d = presets[preset.value];
    if (d) {
      document.getElementById("eye-separation").value = d.eye_separation;
      document.getElementById("viewing-distance").value = d.distance;
      document.getElementById("screen-width").value = d.width;
      document.getElementById("screen-pixels").value = d.resolution ?? "";
    }
    later();
  });
  for (const id of lengthIds) {
    document.getElementById(id).addEventListener("input", () => { preset.value = ""; });
  }
  form.addEventListener("input", (event) => { if (event.target !== preset) later(); });
  form.addEventListener("change", (event) => {
    if (event.target.name === "window-mode") {
      for (const label of form.querySelectorAll("[data-mode]")) label.hidden = label.dataset.mode !== windowMode();
      later();
    }
  });

  for (const button of document.querySelectorAll("[data-copy]")) {
    button.addEventListener("click", async () => {
      const field = document.getElementById(button.dataset.copy);
      const note = document.getElementById("copy-note");
      try {
        await navigator.clipboard.writeText(field.value);
        note.textContent = "copied";
      } catch (exc) {  // no clipboard permission (plain http on another host): select it for Ctrl-C
        field.focus(); field.select();
        note.textContent = "selected: press Ctrl-C to copy";
      }
    });
  }

  api("/api/displays").then((data) => {
    // Accepts a list of {name, ...}, {displays: [...]} or {name: {...}}.
    const list = Array.isArray(data) ? data : Array.isArray(data.displays) ? data.displays
      : Object.entries(data.displays || data).map(([name, d]) => ({ name, ...d }));
    for (const d of list) {
      presets[d.name] = d;
      preset.append(Object.assign(document.createElement("option"), { value: d.name, textContent: d.name }));
    }
    update();
  }).catch((exc) => { showError(exc.message); update(); });
}

window.addEventListener("hashchange", showPage);
document.addEventListener("DOMContentLoaded", showPage);

// ---------------------------------------------------------------- page 5: specular (S3, the `specular` job)
// Runs POST /api/jobs/specular, follows GET /api/jobs/{id}/events (SSE), cancels with DELETE, then shows the
// job's files (the four methods' anaglyphs, the analysis sheets) and its result, report.json, as tables.
// Painting weights and re-optimising are the next step.
const SPEC_METHODS = [["physical", "Physical"], ["optimised", "Optimised"], ["on_surface", "On surface"],
  ["near_surface", "Near surface"]];
const SPEC_SHEETS = ["analysis_disparity.png", "analysis_importance.png", "analysis_rivalry.png", "offsets.png"];
let specJob = null;
let specEvents = null;

async function initSpecular() {
  document.body.dataset.state = "loading";
  try {
    const [data, displays] = await Promise.all([api("/api/data"), api("/api/displays")]);
    const scenes = document.getElementById("spec-scene");
    for (const entry of data.scenes) scenes.add(new Option(entry.name, entry.id));
    const glasses = data.scenes.find((e) => e.id === "scene:glasses");
    if (glasses) scenes.value = glasses.id;
    const select = document.getElementById("spec-display");
    for (const d of displays.displays) select.add(new Option(d.name, d.name));
    if (displays.displays.some((d) => d.name === "samsung-2233rz")) select.value = "samsung-2233rz";
    document.getElementById("spec-run").addEventListener("click", runSpecular);
    document.getElementById("spec-cancel").addEventListener("click", cancelSpecular);
    document.body.dataset.state = "ready";
  } catch (exc) {
    showError(exc.message);
    document.body.dataset.state = "error";
  }
}

function specRequest() {
  const num = (id) => Number(document.getElementById(id).value);
  return {
    scene: document.getElementById("spec-scene").value,
    width: num("spec-width"), height: num("spec-height"), k: num("spec-k"), samples: num("spec-samples"),
    display: document.getElementById("spec-display").value,
    variant: document.getElementById("spec-variant").value,
    weights: [...document.querySelectorAll(".spec-weight")].map((el) => Number(el.value)),
  };
}

function specBusy(busy) {
  document.getElementById("spec-run").disabled = busy;
  document.getElementById("spec-cancel").disabled = !busy;
}

async function runSpecular() {
  showError(null);
  if (specEvents) specEvents.close();
  document.getElementById("spec-result").hidden = true;
  document.body.dataset.state = "loading";
  specBusy(true);
  specJob = null;
  // Cancel is offered once the job has an id: a click before that would cancel nothing
  document.getElementById("spec-cancel").disabled = true;
  let job;
  try {
    job = await api("/api/jobs/specular", specRequest());
  } catch (exc) {
    showError(exc.message);
    specBusy(false);
    document.body.dataset.state = "error";
    return;
  }
  specJob = job.id;
  document.getElementById("spec-cancel").disabled = false;
  const progress = document.getElementById("spec-progress");
  const message = document.getElementById("spec-message");
  specEvents = new EventSource(`/api/jobs/${job.id}/events`);
  specEvents.addEventListener("progress", (ev) => {
    const status = JSON.parse(ev.data);
    progress.value = status.progress || 0;
    message.textContent = `${Math.round(100 * (status.progress || 0))} % ${status.message || ""}`;
  });
  specEvents.addEventListener("end", () => { specEvents.close(); finishSpecular(job.id); });
  specEvents.onerror = () => { specEvents.close(); finishSpecular(job.id); };
}

async function cancelSpecular() {
  if (!specJob) return;
  try { await fetch(`/api/jobs/${specJob}`, { method: "DELETE" }); } catch (exc) { /* reported by the stream */ }
}

async function finishSpecular(id) {
  if (id !== specJob) return;
  specBusy(false);
  let status;
  try { status = await api(`/api/jobs/${id}`); } catch (exc) {
    showError(exc.message);
    document.body.dataset.state = "error";
    return;
  }
  const message = document.getElementById("spec-message");
  if (status.state !== "done") {
    message.textContent = status.state === "cancelled" ? "cancelled" : "";
    if (status.state === "failed") showError(status.error);
    document.body.dataset.state = status.state === "cancelled" ? "ready" : "error";
    return;
  }
  document.getElementById("spec-progress").value = 1;
  message.textContent = status.cached ? "done (cached)" : "done";
  showSpecular(id, status.result);
  document.body.dataset.state = "ready";
}

function specCell(row, value, text, testid) {
  const td = row.insertCell();
  td.textContent = text;
  if (value !== undefined) td.dataset.value = value === null ? "" : String(value);
  if (testid) td.dataset.testid = testid;
  return td;
}

function specShare(v) { return v === null || v === undefined ? "—" : `${(100 * v).toFixed(1)} %`; }

function showSpecular(id, report) {
  const files = (name) => `/api/jobs/${id}/files/${name}`;
  const row = document.getElementById("spec-anaglyphs");
  row.replaceChildren(...SPEC_METHODS.map(([method, label]) => {
    const fig = document.createElement("figure");
    const img = document.createElement("img");
    img.src = files(`${method}_anaglyph.png`);
    img.alt = `${label} anaglyph`;
    img.dataset.testid = `spec-anaglyph-${method}`;
    const caption = document.createElement("figcaption");
    caption.textContent = label;
    fig.append(img, caption);
    return fig;
  }));
  const sheets = document.getElementById("spec-sheets");
  sheets.replaceChildren(...SPEC_SHEETS.map((name) => {
    const img = document.createElement("img");
    img.src = files(name);
    img.alt = name;
    img.dataset.testid = `spec-sheet-${name.replace(".png", "")}`;
    return img;
  }));
  const layers = document.querySelector("#spec-layers tbody");
  layers.replaceChildren();
  for (const layer of report.layers) {
    const tr = layers.insertRow();
    tr.dataset.layer = layer.layer;
    specCell(tr, undefined, `${layer.layer} · ${layer.name}`);
    specCell(tr, layer.pixels, String(layer.pixels), `spec-pixels-${layer.layer}`);
    specCell(tr, layer.comfort_share_before, specShare(layer.comfort_share_before), `spec-comfort-before-${layer.layer}`);
    specCell(tr, layer.comfort_share_after, specShare(layer.comfort_share_after), `spec-comfort-after-${layer.layer}`);
    specCell(tr, layer.matched_before, specShare(layer.matched_before), `spec-matched-before-${layer.layer}`);
    specCell(tr, layer.matched_after, specShare(layer.matched_after), `spec-matched-after-${layer.layer}`);
  }
  const costs = document.querySelector("#spec-costs tbody");
  costs.replaceChildren();
  for (const term of Object.keys(report.cost_before)) {
    const tr = costs.insertRow();
    specCell(tr, undefined, term);
    specCell(tr, report.cost_before[term], fmt(report.cost_before[term]), `spec-cost-before-${term}`);
    specCell(tr, report.cost_after[term], fmt(report.cost_after[term]), `spec-cost-after-${term}`);
  }
  const result = document.getElementById("spec-result");
  result.dataset.job = id;
  result.hidden = false;
}
