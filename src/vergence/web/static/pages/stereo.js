"use strict";

// ---------------------------------------------------------------- page 2: 2D + depth to stereo (the `synthesize` job)
// The input (the built-in example, an image + depth, or a stereo pair) goes up as uploads (POST /api/uploads);
// two `synthesize` jobs (parameter sets A and B, same input) make the pair in every layout of vergence.display
// with the comfort figures. The page shows a chosen layout of A and B wiped against each other, the
// figures of both, the downloads and the equivalent `vergence` command lines. Nothing is computed here.
const ST_FIRST_LAYOUTS = ["anaglyph", "sbs", "cross-eyed", "tb", "rows", "columns", "half-sbs", "half-tb", "checkerboard"];
const stState = { uploads: {}, jobs: { a: null, b: null }, results: { a: null, b: null }, body: null, format: "anaglyph" };

function stSource() { return document.querySelector('input[name="st-source"]:checked').value; }

function stShowSource() {
  const source = stSource();
  for (const div of document.querySelectorAll("#st-form [data-source]")) div.hidden = div.dataset.source !== source;
}

async function stUpload(field, file) {
  // The server tells the format by content; the type only has to be one it accepts.
  const type = ["image/png", "image/jpeg"].includes(file.type) ? file.type : "application/octet-stream";
  let response;
  try {
    response = await fetch(`/api/uploads?name=${encodeURIComponent(file.name)}`, { method: "POST", headers: { "Content-Type": type }, body: file });
  } catch (exc) {
    throw new ApiError("the workbench server does not answer (/api/uploads): is vergence serve still running?");
  }
  const data = await response.json().catch(() => null);
  if (!response.ok) throw new ApiError(data && data.error ? `${field}: ${data.error}` : `${field}: HTTP ${response.status}`);
  stState.uploads[field] = data;
  stShowUploads();
}

function stShowUploads() {
  const fields = stSource() === "pair" ? ["left", "right"] : ["image", "depth"];
  const shown = fields.filter((f) => stState.uploads[f]).map((f) => {
    const u = stState.uploads[f];
    return `${f}: ${u.name} (${u.kind.toUpperCase()}, ${u.width}×${u.height}, ${u.channels} ch)`;
  });
  document.getElementById("st-uploads").textContent = stSource() === "example" ? "" : shown.join(" · ");
}

function stNumber(input) { return input.value.trim() === "" ? null : Number(input.value); }

// The job's body for one parameter set: the input, the display, then the set's own fields.
function stBody(set) {
  const source = stSource();
  const body = {};
  if (source === "example") {
    body.example = document.getElementById("st-scene").value;
    body.example_width = Number(document.getElementById("st-example-width").value);
    body.example_height = Number(document.getElementById("st-example-height").value);
  } else if (source === "depth") {
    for (const f of ["image", "depth"]) {
      if (!stState.uploads[f]) throw new ApiError(`choose the ${f} file first (or use the built-in example)`);
      body[f] = stState.uploads[f].id;
    }
    body.depth_kind = document.getElementById("st-depth-kind").value;
    const scale = stNumber(document.getElementById("st-depth-scale"));
    if (scale !== null) body.depth_scale = scale;
  } else {
    for (const f of ["left", "right"]) {
      if (!stState.uploads[f]) throw new ApiError(`choose the ${f} view first (or use the built-in example)`);
      body[f] = stState.uploads[f].id;
    }
    body.max_disparity = Number(document.getElementById("st-max-disparity").value);
  }
  body.display = document.getElementById("st-display").value;
  const control = document.querySelector(`#st-form [data-set="${set}"][data-field="control"]`).value;
  for (const input of document.querySelectorAll(`#st-form [data-set="${set}"]`)) {
    const field = input.dataset.field;
    if (field === "control" || (ST_CONTROL_FIELDS.has(field) && !ST_CONTROLS[control].fields.includes(field))) continue;
    const value = input.tagName === "SELECT" ? input.value : stNumber(input);
    if (value !== null) body[field] = value;
  }
  return body;
}

// The depth controls of `vergence synthesize` (exactly one per set) and the fields each sends.
const ST_CONTROLS = {
  arcmin: { label: "budget, arcmin", fields: ["budget_arcmin"] },
  px: { label: "budget, pixels", fields: ["budget_px"] },
  sensor: { label: "shift-sensor rig", fields: ["focal_px", "interaxial"] },
};
const ST_CONTROL_FIELDS = new Set(Object.values(ST_CONTROLS).flatMap((c) => c.fields));

function stControls() {
  for (const select of document.querySelectorAll(".st-control")) {
    for (const [value, c] of Object.entries(ST_CONTROLS)) select.add(new Option(c.label, value));
    select.value = "arcmin";
  }
}

// The same with the CLI: vergence synthesize (after vergence render or vergence match for those inputs).
function stCli(set, body, format) {
  const q = shellQuote;
  let before = "", image, depth;
  const options = { out: `stereo-${set}` };
  if (body.example !== undefined) {
    const scene = document.getElementById("st-scene").selectedOptions[0];
    before = `vergence render ${q(scene ? scene.textContent : body.example)} --width ${body.example_width} ` +
      `--height ${body.example_height} --depth 0 --samples 4 --out example && `;
    image = "example/render_beauty.png"; depth = "example/render_depth.pfm";
  } else if (body.left !== undefined) {
    const left = stState.uploads.left.name || "left.png", right = stState.uploads.right.name || "right.png";
    before = `vergence match ${q(left)} ${q(right)} --max-disparity ${body.max_disparity} --out disparity.pfm && `;
    image = left; depth = "disparity.pfm"; options.depth_kind = "disparity";
  } else {
    image = stState.uploads.image.name || "image.png"; depth = stState.uploads.depth.name || "depth.npy";
    options.depth_kind = body.depth_kind;
    if (body.depth_scale !== undefined) options.depth_scale = body.depth_scale;
  }
  options.display = body.display;
  for (const key of ["budget_arcmin", "budget_px", "focal_px", "interaxial", "convergence", "smooth_sigma", "fill"]) {
    if (body[key] !== undefined) options[key] = body[key];
  }
  options.format = format;
  return before + cliLine("synthesize", options).replace("vergence synthesize", `vergence synthesize ${q(image)} ${q(depth)}`);
}

function stBusy(busy) {
  document.getElementById("st-run").disabled = busy;
  document.getElementById("st-example").disabled = busy;
  if (!busy) { stState.running = null; document.getElementById("st-cancel").disabled = true; }
}

async function stRun() {
  showError(null);
  let bodies;
  try { bodies = { a: stBody("a"), b: stBody("b") }; } catch (exc) {
    showError(exc.message); document.body.dataset.state = "error"; return;
  }
  document.body.dataset.state = "loading";
  document.getElementById("st-results").classList.add("stale");
  stBusy(true);
  const progress = document.getElementById("st-progress");
  const message = document.getElementById("st-message");
  try {
    for (const [k, set] of ["a", "b"].entries()) {
      const status = await runJob("synthesize", bodies[set], {
        onStart: (id) => { stState.running = id; document.getElementById("st-cancel").disabled = false; },
        onProgress: (s) => {
          progress.value = (k + (s.progress || 0)) / 2;
          message.textContent = `${set.toUpperCase()}: ${Math.round(100 * (s.progress || 0))} % ${s.message || ""}`;
        },
      });
      if (status.state === "cancelled") {
        stBusy(false);
        message.textContent = "cancelled";
        document.getElementById("st-results").classList.remove("stale");
        document.body.dataset.state = "ready";
        return;
      }
      if (status.state !== "done") {
        throw new ApiError(status.state === "failed" ? `${set.toUpperCase()}: ${status.error}` : `${set.toUpperCase()}: ${status.state}`);
      }
      stState.jobs[set] = status.id;
      stState.results[set] = status.result;
    }
  } catch (exc) {
    stBusy(false);
    message.textContent = "";
    showError(exc.message);
    document.body.dataset.state = "error";
    return;
  }
  stState.body = bodies;
  progress.value = 1;
  message.textContent = "done";
  stBusy(false);
  stShow();
  document.body.dataset.state = "ready";
}

function stShow() {
  stOv.applied = null;  // the CLI lines carry no note of the last result's HIT until the new overlays are drawn
  const { a } = stState.results;
  const select = document.getElementById("st-format");
  const layouts = Object.keys(a.layouts);
  const ordered = [...ST_FIRST_LAYOUTS.filter((l) => layouts.includes(l)), ...layouts.filter((l) => !ST_FIRST_LAYOUTS.includes(l))];
  if (select.options.length !== ordered.length) {
    select.replaceChildren(...ordered.map((l) => new Option(l, l)));
  }
  if (!layouts.includes(stState.format)) stState.format = ordered[0];
  select.value = stState.format;
  document.getElementById("st-empty").hidden = true;
  document.getElementById("st-shown").hidden = false;
  document.getElementById("st-results").classList.remove("stale");
  document.getElementById("st-results").dataset.jobA = stState.jobs.a;
  document.getElementById("st-results").dataset.jobB = stState.jobs.b;
  stShowFormat();
  stShowComfort();
  stOv.shift = 0;
  stLoadOverlays(document.getElementById("st-ov-set").value).catch(stOverlaysError);
}

function stShowFormat() {
  const format = stState.format;
  for (const set of ["a", "b"]) {
    const url = jobFile(stState.jobs[set], stState.results[set].layouts[format]);
    document.getElementById(`st-img-${set}`).src = url;
    const link = document.getElementById(`st-download-${set}`);
    link.href = url;
    link.textContent = `${set.toUpperCase()}: ${stState.results[set].layouts[format]}`;
    link.download = `${set}_${stState.results[set].layouts[format]}`;
    document.getElementById(`st-cli-${set}`).value = stCli(set, stState.body[set], format);
  }
  for (const view of ["left", "right"]) document.getElementById(`st-${view}-a`).href = jobFile(stState.jobs.a, `${view}.png`);
  document.getElementById("st-json-a").href = jobFile(stState.jobs.a, "synthesis.json");
  document.getElementById("st-wipe-box").dataset.format = format;
  stCliNotes();
}

function stWipe(percent) {
  const p = Math.max(0, Math.min(100, percent));
  document.getElementById("st-img-b").style.clipPath = `inset(0 0 0 ${p}%)`;
  document.getElementById("st-wipe-line").style.left = `${p}%`;
  document.getElementById("st-wipe-box").dataset.split = String(p);
  const slider = document.getElementById("st-wipe");
  if (Number(slider.value) !== Math.round(p)) slider.value = String(Math.round(p));
}

// The comfort figures of A and B: every number shown is the job's own (data-value holds it unrounded).
const ST_ROWS = [
  ["min_arcmin", "Nearest parallax (arcmin)", (c) => c.min_arcmin, (v) => fmt(v)],
  ["max_arcmin", "Farthest parallax (arcmin)", (c) => c.max_arcmin, (v) => fmt(v)],
  ["zone_min_arcmin", "Comfort zone from (arcmin)", (c) => c.zone_min_arcmin, (v) => fmt(v)],
  ["zone_max_arcmin", "Comfort zone to (arcmin)", (c) => c.zone_max_arcmin, (v) => fmt(v)],
  ["outside_share", "Pixels outside the zone", (c) => c.outside_share, (v) => `${(100 * v).toFixed(1)} %`],
  ["excess_arcmin", "Leaves the zone by (arcmin)", (c) => c.excess_arcmin, (v) => fmt(v)],
  ["min_px", "Nearest parallax (display px)", (c) => c.min_px, (v) => fmt(v)],
  ["max_px", "Farthest parallax (display px)", (c) => c.max_px, (v) => fmt(v)],
  ["divergence_px", "Divergence limit (display px)", (c) => c.divergence_px, (v) => fmt(v)],
  ["inside", "Inside the zone", (c) => c.inside, (v) => (v ? "yes" : "no")],
  ["diverges", "Eyes diverge", (c) => c.diverges, (v) => (v ? "yes" : "no")],
];

function stShowComfort() {
  const body = document.querySelector("#st-comfort tbody");
  body.replaceChildren();
  for (const [key, label, get, show] of ST_ROWS) {
    const tr = body.insertRow();
    tr.insertCell().textContent = label;
    for (const set of ["a", "b"]) {
      const value = get(stState.results[set].comfort);
      const td = tr.insertCell();
      td.textContent = show(value);
      td.dataset.value = String(value);
      td.dataset.testid = `st-${set}-${key}`;
    }
  }
  const warnings = document.getElementById("st-warnings");
  warnings.replaceChildren(...["a", "b"].flatMap((set) => stState.results[set].warnings.map((w) => {
    const li = document.createElement("li");
    li.textContent = `${set.toUpperCase()}: ${w}`;
    li.title = w;
    return li;
  })));
  stComfortPlot();
}

function stComfortPlot() {
  const svg = document.getElementById("st-comfort-plot");
  svg.replaceChildren();
  const a = stState.results.a.comfort, b = stState.results.b.comfort;
  const lo = Math.min(a.zone_min_arcmin, a.min_arcmin, b.min_arcmin) * 1.15;
  const hi = Math.max(a.zone_max_arcmin, a.max_arcmin, b.max_arcmin) * 1.15;
  const left = 60, right = 14, width = 560;
  const x = (v) => left + (v - lo) / (hi - lo || 1) * (width - left - right);
  svg.append(el("rect", { x: x(a.zone_min_arcmin), y: 6, width: x(a.zone_max_arcmin) - x(a.zone_min_arcmin), height: 56, class: "st-zone" }));
  svg.append(el("line", { x1: x(0), x2: x(0), y1: 4, y2: 64, class: "grid" }));
  for (const [row, set, c] of [[0, "A", a], [1, "B", b]]) {
    const y = 14 + row * 26;
    svg.append(el("text", { x: left - 8, y: y + 10, "text-anchor": "end", class: "label" }, set));
    svg.append(el("rect", { x: x(c.min_arcmin), y, width: Math.max(1, x(c.max_arcmin) - x(c.min_arcmin)), height: 14,
      class: `st-range st-range-${set.toLowerCase()}${c.inside ? "" : " st-out"}`, "data-testid": `st-bar-${set.toLowerCase()}` }));
  }
  for (const t of niceTicks(lo, hi, 6).ticks) {
    if (t < lo || t > hi) continue;
    svg.append(el("line", { x1: x(t), x2: x(t), y1: 64, y2: 68, class: "frame" }));
    svg.append(el("text", { x: x(t), y: 80, "text-anchor": "middle" }, fmt(t, 3)));
  }
  svg.append(el("text", { x: (left + width - right) / 2, y: 96, "text-anchor": "middle", class: "label" },
    "vergence change, arcmin (negative: in front of the screen)"));
}

// ---------------------------------------------------------------- overlays (docs/workbench.md, "Overlays")
// For one result (A or B): its parallax map P = x_r - x_l (parallax.npy of the job: px of the pair, positive
// behind the screen, NaN unknown) and GET /api/stereo/{id}/overlay (the comfort zone, the divergence limit and
// the colour scale converted to px of the pair by the library, the stereo-window rule of vergence.video).
// The pair is drawn here as a red-cyan anaglyph, shifted by the horizontal image translation (HIT) s: the
// left view moves -s/2 px, the right view +s/2 px, so every parallax becomes P + s (no re-synthesis;
// uncovered columns are black). The heat map, the histogram, its shares and the window check follow s.
// The colour map: t in [0, 1] from the parallax (0: -scale arcmin, in front; 0.5: the screen; 1: +scale
// arcmin, behind), linear in px on each side of 0 and clamped; RGB interpolated between ST_HEAT_STOPS.
const ST_HEAT_STOPS = [[0, [178, 24, 43]], [0.25, [239, 138, 98]], [0.5, [247, 247, 247]], [0.75, [103, 169, 207]], [1, [33, 102, 172]]];
const ST_HIST_BINS = 40;  // about this many bins over the range at s = 0; their width stays as s moves
const ST_BIN_STEPS = [1, 2, 2.5, 5];
const stOv = { set: null, geo: null, P: null, W: 0, H: 0, views: null, bins: null, shift: 0, token: 0 };

// A float32 (H, W) NPY file (numpy's format 1.0-3.0, little-endian, C order) as {shape, data}.
function stParseNpy(buffer) {
  const bytes = new Uint8Array(buffer);
  if (bytes[0] !== 0x93 || String.fromCharCode(...bytes.slice(1, 6)) !== "NUMPY") throw new ApiError("parallax.npy is not an NPY file");
  const view = new DataView(buffer);
  const major = bytes[6];
  const headerLen = major === 1 ? view.getUint16(8, true) : view.getUint32(8, true);
  const start = major === 1 ? 10 : 12;
  const header = new TextDecoder().decode(bytes.slice(start, start + headerLen));
  if (!/'descr':\s*'<f4'/.test(header) || /'fortran_order':\s*True/.test(header)) throw new ApiError(`parallax.npy: expected little-endian float32 in C order; got ${header.trim()}`);
  const shape = header.match(/'shape':\s*\((\d+),\s*(\d+)\)/);
  if (!shape) throw new ApiError(`parallax.npy: expected a 2-D array; got ${header.trim()}`);
  const [h, w] = [Number(shape[1]), Number(shape[2])];
  return { shape: [h, w], data: new Float32Array(buffer.slice(start + headerLen, start + headerLen + 4 * h * w)) };
}

function stHeatT(v, scale) {
  const [lo, hi] = scale.px;
  return v <= 0 ? 0.5 * (1 - Math.min(v / lo, 1)) : 0.5 + 0.5 * Math.min(v / hi, 1);
}

function stHeatColour(t) {
  for (let i = 1; i < ST_HEAT_STOPS.length; i++) {
    const [t1, c1] = ST_HEAT_STOPS[i];
    if (t <= t1 || i === ST_HEAT_STOPS.length - 1) {
      const [t0, c0] = ST_HEAT_STOPS[i - 1];
      const f = Math.max(0, Math.min(1, (t - t0) / (t1 - t0)));
      return c0.map((c, k) => Math.round(c + f * (c1[k] - c)));
    }
  }
  return ST_HEAT_STOPS[0][1];
}

function stImage(url) {
  return new Promise((resolve, reject) => {
    const img = new Image();
    img.onload = () => resolve(img);
    img.onerror = () => reject(new ApiError(`cannot load ${url}`));
    img.src = url;
  });
}

// Loads the overlays of result `set` (its parallax map, the geometry, both views), then draws them.
async function stLoadOverlays(set) {
  const token = ++stOv.token;
  const id = stState.jobs[set];
  if (!id) return;  // nothing synthesized yet
  const scale = document.getElementById("st-heat-scale").value;
  document.getElementById("st-overlays").dataset.state = "loading";
  const [geo, buffer, left, right] = await Promise.all([
    api(`/api/stereo/${id}/overlay?scale_arcmin=${encodeURIComponent(scale)}`),
    fetch(jobFile(id, "parallax.npy")).then((r) => { if (!r.ok) throw new ApiError(`parallax.npy: HTTP ${r.status}`); return r.arrayBuffer(); }),
    stImage(jobFile(id, "left.png")), stImage(jobFile(id, "right.png")),
  ]);
  if (token !== stOv.token) return;  // a later choice won
  const npy = stParseNpy(buffer);
  Object.assign(stOv, { set, geo, P: npy.data, H: npy.shape[0], W: npy.shape[1], views: { left, right } });
  stOv.bins = stBinsAtZero();
  const extent = Math.max(4, Math.ceil(2 * Math.max(Math.abs(geo.zone_px[0]), geo.zone_px[1], stOv.bins.maxAbs)));
  const hit = document.getElementById("st-hit");
  hit.min = String(-extent); hit.max = String(extent);
  stOv.shift = Math.max(-extent, Math.min(extent, stOv.shift));
  hit.value = String(stOv.shift);
  const box = document.getElementById("st-overlays");
  box.dataset.set = set; box.dataset.job = id;
  stShowVertical();
  stDrawOverlays();
  box.dataset.state = "ready";
}

// The histogram's bins: a width from ST_BIN_STEPS x 10^k giving about ST_HIST_BINS over the range at s = 0,
// edges on its multiples, kept as s moves; the x range fixed so that the bars move with s.
function stBinsAtZero() {
  let lo = Infinity, hi = -Infinity;
  for (const v of stOv.P) if (Number.isFinite(v)) { if (v < lo) lo = v; if (v > hi) hi = v; }
  if (!(hi >= lo)) { lo = 0; hi = 0; }
  const raw = Math.max(hi - lo, 0.5) / ST_HIST_BINS;
  const mag = 10 ** Math.floor(Math.log10(raw));
  const width = ST_BIN_STEPS.map((m) => m * mag).find((w) => w >= raw) || 10 * mag;
  return { width, lo, hi, maxAbs: Math.max(Math.abs(lo), Math.abs(hi)) };
}

function stOvState() {
  const s = stOv.shift;
  const { P, W, H, geo } = stOv;
  const w = stOv.bins.width;
  const counts = new Map();
  let known = 0, outside = 0, diverging = 0, sum = 0;
  const [zlo, zhi] = geo.zone_px;
  for (const p of P) {
    if (!Number.isFinite(p)) continue;
    const v = p + s;
    known++; sum += v;
    if (v < zlo || v > zhi) outside++;
    if (v > geo.divergence_px) diverging++;
    const k = Math.floor(v / w);
    counts.set(k, (counts.get(k) || 0) + 1);
  }
  // The stereo window at each edge (vergence analyze's rule): crossed parallax (-(P + s) > min_px) on at least
  // `share` of the band's pixels (unknown ones count as not); the floating window: the mask_percentile-th
  // percentile of -(P + s) over the band's known pixels, rounded up to whole columns.
  const band = geo.window.band_px;
  const edges = {};
  for (const edge of ["left", "right"]) {
    const x0 = edge === "left" ? 0 : W - band;
    let crossed = 0, first = -1, last = -1;
    const values = [];
    for (let y = 0; y < H; y++) for (let x = x0; x < x0 + band; x++) {
      const p = P[y * W + x];
      if (!Number.isFinite(p)) continue;
      const near = -(p + s);
      if (near > geo.window.min_px) { crossed++; if (first < 0) first = y; last = y; }
      values.push(near);
    }
    const share = crossed / (band * H);
    const violation = share >= geo.window.share;
    let cue = NaN;
    if (values.length) {
      values.sort((a, b) => a - b);
      const pos = geo.window.mask_percentile / 100 * (values.length - 1);
      const i = Math.floor(pos);
      cue = i + 1 < values.length ? values[i] + (pos - i) * (values[i + 1] - values[i]) : values[i];
    }
    edges[edge] = { share, violation, cue, rows: [first, last], width: violation && cue > geo.window.min_px ? Math.ceil(cue) : 0 };
  }
  return { counts, known, outside, diverging, mean: known ? sum / known : NaN, edges };
}

function stDrawOverlays() {
  if (!stOv.geo) return;
  const state = stOvState();
  const floating = document.getElementById("st-float").checked;
  const mask = { left: floating ? state.edges.left.width : 0, right: floating ? state.edges.right.width : 0 };
  stDrawPair(mask);
  stDrawHeat();
  stHeatBar();
  stDrawHistogram(state);
  stShowWindow(state, floating, mask);
  const s = stOv.shift;
  document.getElementById("st-hit-value").textContent = `${s > 0 ? "+" : ""}${s} px`;
  const box = document.getElementById("st-overlays");
  box.dataset.shift = String(s);
  box.dataset.maskLeft = String(mask.left); box.dataset.maskRight = String(mask.right);
  stOv.applied = { shift: s, mask };
  stCliNotes();
}

// The pair at twice its size (a half-pixel shift is a whole canvas pixel), nearest-neighbour.
function stDrawPair(mask) {
  const { W, H, views } = stOv;
  const s = stOv.shift;
  const canvas = document.getElementById("st-pair-canvas");
  canvas.width = 2 * W; canvas.height = 2 * H;
  const eye = (img, dx, maskX, maskW, tint) => {
    const c = document.createElement("canvas");
    c.width = 2 * W; c.height = 2 * H;
    const g = c.getContext("2d");
    g.imageSmoothingEnabled = false;
    g.fillStyle = "#000"; g.fillRect(0, 0, c.width, c.height);
    g.drawImage(img, dx, 0, 2 * W, 2 * H);
    if (maskW > 0) g.fillRect(maskX, 0, 2 * maskW, c.height);  // the floating window (black columns)
    g.globalCompositeOperation = "multiply";
    g.fillStyle = tint; g.fillRect(0, 0, c.width, c.height);
    return c;
  };
  const ctx = canvas.getContext("2d");
  ctx.fillStyle = "#000"; ctx.fillRect(0, 0, canvas.width, canvas.height);
  ctx.globalCompositeOperation = "lighter";
  ctx.drawImage(eye(views.left, -s, 0, mask.left, "#ff0000"), 0, 0);
  ctx.drawImage(eye(views.right, s, 2 * (W - mask.right), mask.right, "#00ffff"), 0, 0);
  ctx.globalCompositeOperation = "source-over";
}

function stDrawHeat() {
  const { W, H, P, geo } = stOv;
  const s = stOv.shift;
  const canvas = document.getElementById("st-heat-canvas");
  canvas.width = W; canvas.height = H;
  const ctx = canvas.getContext("2d");
  const image = ctx.createImageData(W, H);
  for (let i = 0; i < W * H; i++) {
    if (!Number.isFinite(P[i])) continue;  // unknown: transparent
    const [r, g, b] = stHeatColour(stHeatT(P[i] + s, geo.scale));
    image.data.set([r, g, b, 255], 4 * i);
  }
  ctx.putImageData(image, 0, 0);
  canvas.hidden = !document.getElementById("st-heat").checked;
  canvas.style.opacity = String(Number(document.getElementById("st-heat-opacity").value) / 100);
}

// The colour bar: t from 0 to 1 left to right, ticks at the arcmin the server converted (px of the pair below).
function stHeatBar() {
  const svg = document.getElementById("st-heat-bar");
  svg.replaceChildren();
  const { scale, zone_px: zone, display } = stOv.geo;
  const left = 76, right = 24, width = 560, n = 120;
  const x = (t) => left + t * (width - left - right);
  for (let i = 0; i < n; i++) {
    const [r, g, b] = stHeatColour((i + 0.5) / n);
    svg.append(el("rect", { x: x(i / n), y: 4, width: (width - left - right) / n + 0.5, height: 14, fill: `rgb(${r},${g},${b})` }));
  }
  svg.append(el("rect", { x: left, y: 4, width: width - left - right, height: 14, class: "frame" }));
  for (const z of zone) svg.append(el("line", { x1: x(stHeatT(z, scale)), x2: x(stHeatT(z, scale)), y1: 1, y2: 21, class: "st-zone-mark" }));
  for (const tick of scale.ticks) {
    const tx = x(stHeatT(tick.px, scale));
    svg.append(el("line", { x1: tx, x2: tx, y1: 18, y2: 22, class: "frame" }));
    svg.append(el("text", { x: tx, y: 33, "text-anchor": "middle", "data-arcmin": String(tick.arcmin) }, `${fmt(tick.arcmin, 3)}′`));
    svg.append(el("text", { x: tx, y: 45, "text-anchor": "middle", class: "st-px" }, `${fmt(tick.px, 2)}`));
  }
  svg.append(el("text", { x: left - 22, y: 33, "text-anchor": "end", class: "label" }, "arcmin"));
  svg.append(el("text", { x: left - 22, y: 45, "text-anchor": "end", class: "label" }, "px"));
  svg.append(el("text", { x: (left + width - right) / 2, y: 57, "text-anchor": "middle", class: "label" },
    `vergence on ${display} · red: in front of the screen, blue: behind · green: comfort zone`));
}

function stDrawHistogram(state) {
  const { geo, bins } = stOv;
  const w = bins.width;
  const bars = [...state.counts.entries()].sort((a, b) => a[0] - b[0]).map(([k, c]) => ({
    lo: Number((k * w).toPrecision(12)), hi: Number(((k + 1) * w).toPrecision(12)), value: 100 * c / state.known,
    cls: (k + 1) * w <= geo.zone_px[0] || k * w >= geo.zone_px[1] ? "st-bar-out" : "" }));
  const reach = Number(document.getElementById("st-hit").max);
  const lo = Math.min(bins.lo - reach, geo.zone_px[0]) - w, hi = Math.max(bins.hi + reach, geo.zone_px[1]) + w;
  const divOn = geo.divergence_px <= hi + 0.5 * (hi - lo);  // far off the plot: said beside its share instead
  const xhi = divOn ? Math.max(hi, geo.divergence_px + w) : hi;
  const svg = document.getElementById("st-hist");
  drawHistogram(svg, bars, {
    xrange: [lo, xhi],
    xlabel: "parallax P + s, px of the pair (negative: in front of the screen)",
    ylabel: "% of pixels",
    bands: [{ from: geo.zone_px[0], to: geo.zone_px[1], cls: "st-zone", label: `comfort zone ±${fmt(geo.zone_arcmin[1], 3)}′` },
      ...(divOn ? [{ from: geo.divergence_px, to: xhi, cls: "shade", label: "diverging" }] : [])],
    vlines: [{ x: 0, label: "screen" }, { x: geo.divergence_px, label: "", cls: "st-div-line" }],
  });
  svg.dataset.mean = String(state.mean);
  svg.dataset.shift = String(stOv.shift);
  svg.dataset.binWidth = String(w);
  for (const [id, count] of [["st-share-zone", state.outside], ["st-share-div", state.diverging]]) {
    const share = state.known ? count / state.known : 0;
    const b = document.getElementById(id);
    b.textContent = `${(100 * share).toFixed(1)} % (${count} of ${state.known})` +
      (id === "st-share-div" ? `; the limit at ${fmt(geo.divergence_px, 3)} px${divOn ? "" : ", off the plot"}` : "");
    b.dataset.value = String(share);
  }
}

function stShowWindow(state, floating, mask) {
  const { geo } = stOv;
  const list = document.getElementById("st-window");
  list.replaceChildren(...["left", "right"].map((edge) => {
    const e = state.edges[edge];
    const li = document.createElement("li");
    li.dataset.testid = `st-window-${edge}`;
    li.dataset.violation = String(e.violation);
    li.dataset.share = String(e.share);
    li.dataset.width = String(e.width);
    const band = `${(100 * e.share).toFixed(1)} % of the ${geo.window.band_px}-px band in front of the screen`;
    li.textContent = e.violation
      ? `${edge} edge: stereo-window violation, rows ${e.rows[0]}–${e.rows[1]} (${band}, ≥ ${100 * geo.window.share} %): ` +
        `a floating window of ${e.width} px masks it`
      : `${edge} edge: no violation (${band})`;
    li.className = e.violation ? (mask[edge] ? "st-masked" : "st-violation") : "";
    return li;
  }));
  const note = document.getElementById("st-float-note");
  const applied = ["left", "right"].filter((e) => mask[e] > 0)
    .map((e) => `${e} edge of the ${e} view: ${mask[e]} px black (the window's edge ${mask[e]} px in front of the screen)`);
  note.textContent = !floating ? "Floating window off."
    : applied.length ? `Floating window applied in the shown pair: ${applied.join("; ")}.` : "Floating window on: no edge needs it.";
}

function stShowVertical() {
  const p = document.getElementById("st-vertical");
  const r = stOv.geo.row_alignment;
  p.hidden = !r;
  p.classList.remove("st-warn");
  if (!r) return;
  if (r.error) {
    p.textContent = `Vertical disparity (rectify --check's measure): not measured: ${r.error}`;
    p.dataset.value = "";
    return;
  }
  const display = r.median_abs_dy_px * stOv.geo.display_px_per_px;
  p.textContent = `Vertical disparity (rectify --check's measure, median |y_r − y_l| of ${r.matches} SIFT + RANSAC matches): ` +
    `${fmt(r.median_abs_dy_px, 3)} px of the pair (90th percentile ${fmt(r.p90_abs_dy_px, 3)} px; ${fmt(display, 3)} px on ${stOv.geo.display})` +
    (r.above ? ` — above ${r.threshold_px} px: rectify the pair (vergence rectify) before matching` : ` — below ${r.threshold_px} px`);
  p.dataset.value = String(r.median_abs_dy_px);
  p.classList.toggle("st-warn", r.above);
}

// The CLI lines say what the page applied that the command does not (HIT, floating window).
function stCliNotes() {
  if (!stOv.applied || !stState.body) return;
  for (const set of ["a", "b"]) {
    const field = document.getElementById(`st-cli-${set}`);
    const base = stCli(set, stState.body[set], stState.format);
    const { shift, mask } = stOv.applied;
    const parts = [];
    const signed = (v) => `${v > 0 ? "+" : ""}${v}`;
    if (set === stOv.set && shift !== 0) parts.push(`HIT ${signed(shift)} px (left view ${signed(-shift / 2)} px, right view ${signed(shift / 2)} px)`);
    if (set === stOv.set && (mask.left || mask.right)) parts.push(`floating window: left ${mask.left} px, right ${mask.right} px`);
    field.value = parts.length ? `${base}  # shown on the page with ${parts.join(", ")}: not applied by this command` : base;
  }
  const link = document.getElementById("st-save-shown");
  const { shift, mask } = stOv.applied;
  const tag = `${stOv.set}_anaglyph_hit${shift >= 0 ? "+" : ""}${shift}px${mask.left || mask.right ? `_window-l${mask.left}-r${mask.right}` : ""}`;
  link.download = `${tag}.png`;
  link.textContent = `Download the shown pair (${stOv.set.toUpperCase()}, red-cyan anaglyph at 2×, HIT ${shift >= 0 ? "+" : ""}${shift} px` +
    `${mask.left || mask.right ? `, floating window left ${mask.left} px, right ${mask.right} px` : ""})`;
}

function stOverlaysError(exc) {
  document.getElementById("st-overlays").dataset.state = "error";
  showError(exc.message);
  document.body.dataset.state = "error";
}

function stInitOverlays() {
  // One redraw per frame however fast the slider moves (a large pair takes a while to count).
  let pending = false;
  const redraw = () => {
    if (pending) return;
    pending = true;
    requestAnimationFrame(() => { pending = false; stDrawOverlays(); });
  };
  document.getElementById("st-ov-set").addEventListener("change", (ev) => stLoadOverlays(ev.target.value).catch(stOverlaysError));
  document.getElementById("st-heat-scale").addEventListener("change", () => stLoadOverlays(stOv.set).catch(stOverlaysError));
  document.getElementById("st-heat").addEventListener("change", redraw);
  document.getElementById("st-heat-opacity").addEventListener("input", () => {
    document.getElementById("st-heat-canvas").style.opacity = String(Number(document.getElementById("st-heat-opacity").value) / 100);
  });
  document.getElementById("st-hit").addEventListener("input", (ev) => { stOv.shift = Number(ev.target.value); redraw(); });
  document.getElementById("st-hit-reset").addEventListener("click", () => { stOv.shift = 0; document.getElementById("st-hit").value = "0"; redraw(); });
  document.getElementById("st-float").addEventListener("change", redraw);
  document.getElementById("st-save-shown").addEventListener("click", (ev) => {
    const link = ev.currentTarget;
    link.href = document.getElementById("st-pair-canvas").toDataURL("image/png");
  });
}

async function initStereo() {
  document.body.dataset.state = "loading";
  try {
    const [data, displays, jobs] = await Promise.all([api("/api/data"), api("/api/displays"), api("/api/jobs")]);
    const scenes = document.getElementById("st-scene");
    for (const entry of data.scenes) scenes.add(new Option(entry.name, entry.id));
    if (data.scenes.some((e) => e.id === "scene:tabletop")) scenes.value = "scene:tabletop";
    const select = document.getElementById("st-display");
    for (const d of displays.displays) select.add(new Option(d.name, d.name));
    const params = jobs.kinds.find((k) => k.name === "synthesize").parameters.properties;
    select.value = params.display.default;
    for (const fill of document.querySelectorAll(".st-fill")) {
      for (const name of params.fill.enum) fill.add(new Option(name, name));
      fill.value = params.fill.default;
    }
    stControls();
  } catch (exc) {
    showError(exc.message);
    document.body.dataset.state = "error";
    return;
  }
  for (const radio of document.querySelectorAll('input[name="st-source"]')) {
    radio.addEventListener("change", () => { stShowSource(); stShowUploads(); });
  }
  for (const field of ["image", "depth", "left", "right"]) {
    document.getElementById(`st-file-${field}`).addEventListener("change", async (event) => {
      const file = event.target.files[0];
      if (!file) return;
      showError(null);
      document.body.dataset.state = "loading";
      try { await stUpload(field, file); document.body.dataset.state = "ready"; } catch (exc) {
        delete stState.uploads[field];
        showError(exc.message);
        document.body.dataset.state = "error";
      }
    });
  }
  document.getElementById("st-example").addEventListener("click", () => {
    document.querySelector('input[name="st-source"][value="example"]').checked = true;
    stShowSource();
    stRun();
  });
  document.getElementById("st-run").addEventListener("click", stRun);
  document.getElementById("st-cancel").addEventListener("click", () => { if (stState.running) cancelJob(stState.running); });
  document.getElementById("st-format").addEventListener("change", (event) => { stState.format = event.target.value; stShowFormat(); });
  document.getElementById("st-wipe").addEventListener("input", (event) => stWipe(Number(event.target.value)));
  const box = document.getElementById("st-wipe-box");
  const drag = (event) => {
    if (event.type !== "pointerdown" && !(event.buttons & 1)) return;
    const rect = box.getBoundingClientRect();
    stWipe(100 * (event.clientX - rect.left) / rect.width);
    event.preventDefault();
  };
  box.addEventListener("pointerdown", drag);
  box.addEventListener("pointermove", drag);
  stWipe(50);
  for (const button of document.querySelectorAll("#page-stereo [data-copy]")) {
    button.addEventListener("click", async () => {
      const field = document.getElementById(button.dataset.copy);
      const note = document.getElementById("st-copy-note");
      try { await navigator.clipboard.writeText(field.value); note.textContent = "copied"; } catch (exc) {
        field.focus(); field.select(); note.textContent = "selected: press Ctrl-C to copy";
      }
    });
  }
  offerVR(document.getElementById("st-vr"), () => {
    if (!stState.jobs.a) throw new Error("synthesize a pair first");
    return { left: jobFile(stState.jobs.a, "left.png"), right: jobFile(stState.jobs.a, "right.png") };
  });
  stInitOverlays();
  stShowSource();
  document.body.dataset.state = "ready";
}

registerPage("stereo", initStereo);
