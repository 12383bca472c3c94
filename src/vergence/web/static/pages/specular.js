// Page 5: specular (S3). Runs POST /api/jobs/specular (progress as server-sent events, Cancel), shows the
// four methods' anaglyphs, the analysis sheets and report.json as tables; then paints per-layer weights on
// the layer pictures the job wrote (layer_<n>.png) and re-optimises with POST /api/jobs/specular-reoptimise,
// which reuses the job's offset table (SpecularResult.reoptimise): the painted maps travel as .npy uploads
// (POST /api/uploads), exactly as `vergence specular --weight-map [TERM:]LAYER=FILE` reads them.
"use strict";

const SPEC_METHODS = [["physical", "Physical"], ["optimised", "Optimised"], ["on_surface", "On surface"],
  ["near_surface", "Near surface"]];
const SPEC_SHEETS = ["analysis_disparity.png", "analysis_importance.png", "analysis_rivalry.png", "offsets.png"];
// The sheet drawn large is at most this many times its own size (it is drawn at 100 dpi: 9 pt text, 12.5 px).
const SPEC_SHEET_ZOOM = 1.5;
// The comfort overlay: the chosen layer's pixels outside the zone after the latest solve, in magenta.
const SPEC_OUTSIDE_RGBA = [255, 0, 200, 0.75];
// The painted weight's tint on the picture: blue where it is below 1 (the term matters less), red above.
const SPEC_TINT_ALPHA = 0.6;
const SPEC_TINT_SATURATION = 4;  // a weight of 1 + 4 gets the full red tint

const spec = {
  job: null,       // the job in flight (Cancel)
  base: null,      // the done specular job whose table re-optimising reuses
  shown: null,     // the job whose files are shown (the base or its last re-optimisation)
  width: 0, height: 0,
  maps: new Map(), // "layer|term" -> Float32Array(width * height) of painted weights (1: unpainted)
  picture: null,   // ImageData of the chosen layer's picture
  painting: false,
  stroked: false,  // the pointer painted since it went down
  report: null,    // the shown result's report
  overlay: null,   // {id, n, data: Float32Array(n * height * width)} horizontal disparity after, arcmin (NaN: none)
  running: false,  // a re-optimisation is being asked for or shown
  again: false,    // a stroke ended while a re-optimisation ran: run again when it ends
  strokeMs: [],    // stroke (pointer up) to the new anaglyph and overlay drawn, ms, one per answered stroke
  sheet: SPEC_SHEETS[0],
};

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
    document.getElementById("spec-cancel").addEventListener("click", () => { if (spec.job) cancelJob(spec.job); });
    document.getElementById("spec-reoptimise").addEventListener("click", () => reoptimiseSpecular(null));
    document.getElementById("spec-overlay").addEventListener("change", specDraw);
    document.getElementById("spec-draw-sheets").addEventListener("click", () => specSheets(spec.shown, true));
    document.getElementById("spec-clear").addEventListener("click", () => { spec.maps.clear(); specDraw(); });
    document.getElementById("spec-layer").addEventListener("change", specLoadPicture);
    document.getElementById("spec-term").addEventListener("change", specDraw);
    specCanvasEvents(document.getElementById("spec-canvas"));
    specInitOverlays();
    // the right eye is one render for every re-optimisation: the base job's (a re-optimisation writes it on request)
    offerVR(document.getElementById("spec-vr"), () => ({
      left: jobFile(spec.shown, "optimised_left.png"), right: jobFile(spec.base, "optimised_right.png") }));
    document.body.dataset.state = "ready";
  } catch (exc) {
    showError(exc.message);
    document.body.dataset.state = "error";
  }
}

function specWeights() { return [...document.querySelectorAll(".spec-weight")].map((el) => Number(el.value)); }

function specRequest() {
  const num = (id) => Number(document.getElementById(id).value);
  return {
    scene: document.getElementById("spec-scene").value,
    width: num("spec-width"), height: num("spec-height"), k: num("spec-k"), samples: num("spec-samples"),
    display: document.getElementById("spec-display").value,
    fit: document.getElementById("spec-fit").value,
    variant: document.getElementById("spec-variant").value,
    weights: specWeights(),
  };
}

function specBusy(busy) {
  document.getElementById("spec-run").disabled = busy;
  document.getElementById("spec-reoptimise").disabled = busy;
  // Cancel is offered once the job has an id (onStart): a click before that would cancel nothing
  document.getElementById("spec-cancel").disabled = true;
}

function specProgress(status) {
  document.getElementById("spec-progress").value = status.progress || 0;
  document.getElementById("spec-message").textContent =
    `${Math.round(100 * (status.progress || 0))} % ${status.message || ""}`;
}

// Run a job from the page: busy while it runs, Cancel once it has an id; the final status, or null when
// it was refused, failed or cancelled (then the message or the error box says so).
async function specJob(kind, body, messageId) {
  showError(null);
  document.body.dataset.state = "loading";
  specBusy(true);
  spec.job = null;
  let status;
  try {
    status = await runJob(kind, body, {
      onStart: (id) => { spec.job = id; document.getElementById("spec-cancel").disabled = false; },
      onProgress: specProgress,
    });
  } catch (exc) {
    showError(exc.message);
    document.body.dataset.state = "error";
    return null;
  } finally {
    specBusy(false);
    spec.job = null;
  }
  const message = document.getElementById(messageId);
  if (!jobDone(status, message)) return null;
  document.getElementById("spec-progress").value = 1;
  document.getElementById("spec-message").textContent = status.cached ? "done (cached)" : "done";
  return status;
}

async function runSpecular() {
  document.getElementById("spec-result").hidden = true;
  const status = await specJob("specular", specRequest(), "spec-message");
  if (!status) return;
  spec.base = status.id;
  spec.maps.clear();
  document.getElementById("spec-reopt-message").textContent = "";
  specLayers(status.result);
  await showSpecular(status.id, status.result);
  await specLoadPicture();
  document.body.dataset.state = "ready";
}

// ---------------------------------------------------------------- painting
// Every layer is listed; one with no matched pixel in the physical pair is greyed out (disabled), its tooltip
// saying why: the server refuses its paint (422), since no weight can move its offsets.
function specLayers(report) {
  const select = document.getElementById("spec-layer");
  select.replaceChildren();
  for (const layer of report.layers) {
    const option = new Option(
      `${layer.layer} · ${layer.name} (${layer.matched_pixels_before} of ${layer.pixels} px matched)`,
      String(layer.layer));
    if (!report.specular || !layer.matched_pixels_before) {
      option.disabled = true;
      option.title = !report.specular ? "nothing specular is in view in this run: it has no offsets to solve"
        : `layer ${layer.layer} (${layer.name}) has no matched pixel in the physical pair `
        + `(${layer.pixels} px with a surface): no weight can move its offsets`;
      option.dataset.testid = "spec-layer-greyed";
    }
    select.add(option);
  }
  // the first specular layer that can be painted (the first hit can too: its weights enter the others' solve)
  const first = [...select.options].find((o) => !o.disabled && o.value !== "1")
    || [...select.options].find((o) => !o.disabled);
  if (first) select.value = first.value;
  const none = !first;
  document.getElementById("spec-reoptimise").disabled = false;
  document.getElementById("spec-painted").textContent = none
    ? "no reflected or refracted layer in view: nothing to paint" : "nothing painted";
}

function specKey() {
  return `${document.getElementById("spec-layer").value}|${document.getElementById("spec-term").value}`;
}

async function specLoadPicture() {
  const layer = document.getElementById("spec-layer").value;
  const canvas = document.getElementById("spec-canvas");
  if (!layer) { canvas.hidden = true; spec.picture = null; return; }
  const img = new Image();
  img.src = jobFile(spec.base, `layer_${layer}.png`);
  try { await img.decode(); } catch (exc) { showError(`layer_${layer}.png: the picture cannot be loaded`); return; }
  spec.width = img.naturalWidth;
  spec.height = img.naturalHeight;
  canvas.width = spec.width;
  canvas.height = spec.height;
  canvas.hidden = false;
  const ctx = canvas.getContext("2d");
  ctx.drawImage(img, 0, 0);
  spec.picture = ctx.getImageData(0, 0, spec.width, spec.height);
  specDraw();
}

// The picture with the current layer and term's painted weights tinted over it.
function specDraw() {
  const canvas = document.getElementById("spec-canvas");
  if (spec.picture) {
    const out = new ImageData(new Uint8ClampedArray(spec.picture.data), spec.width, spec.height);
    const map = spec.maps.get(specKey());
    if (map) {
      for (let i = 0; i < map.length; i++) {
        const w = map[i];
        if (w === 1) continue;
        const [r, g, b, a] = w < 1 ? [40, 90, 255, SPEC_TINT_ALPHA * (1 - w)]
          : [230, 40, 30, SPEC_TINT_ALPHA * Math.min(1, (w - 1) / SPEC_TINT_SATURATION)];
        out.data[4 * i] += (r - out.data[4 * i]) * a;
        out.data[4 * i + 1] += (g - out.data[4 * i + 1]) * a;
        out.data[4 * i + 2] += (b - out.data[4 * i + 2]) * a;
      }
    }
    specOutside(out);
    canvas.getContext("2d").putImageData(out, 0, 0);
  }
  const painted = [...spec.maps.entries()].map(([key, map]) => {
    const [layer, term] = key.split("|");
    const count = map.reduce((n, w) => n + (w !== 1), 0);
    return count ? `layer ${layer} · ${term || "every term"}: ${count} px` : null;
  }).filter(Boolean);
  const note = document.getElementById("spec-painted");
  if (document.getElementById("spec-layer").options.length) {
    note.textContent = painted.length ? painted.join("; ") : "nothing painted";
  }
  note.dataset.maps = String(painted.length);
}

function specPaintAt(event) {
  const canvas = event.currentTarget;
  const rect = canvas.getBoundingClientRect();
  const cx = (event.clientX - rect.left) * spec.width / rect.width;
  const cy = (event.clientY - rect.top) * spec.height / rect.height;
  const radius = Math.max(1, Number(document.getElementById("spec-brush-size").value) || 1);
  const value = Number(document.getElementById("spec-brush-value").value);
  if (!(value >= 0 && Number.isFinite(value))) { showError("the brush weight must be a number >= 0"); return; }
  const key = specKey();
  if (!spec.maps.has(key)) spec.maps.set(key, new Float32Array(spec.width * spec.height).fill(1));
  const map = spec.maps.get(key);
  for (let y = Math.max(0, Math.floor(cy - radius)); y <= Math.min(spec.height - 1, Math.ceil(cy + radius)); y++) {
    for (let x = Math.max(0, Math.floor(cx - radius)); x <= Math.min(spec.width - 1, Math.ceil(cx + radius)); x++) {
      if ((x + 0.5 - cx) ** 2 + (y + 0.5 - cy) ** 2 <= radius * radius) map[y * spec.width + x] = value;
    }
  }
  specDraw();
}

function specCanvasEvents(canvas) {
  canvas.addEventListener("pointerdown", (event) => {
    if (!spec.picture) return;
    spec.painting = true;
    spec.stroked = true;
    canvas.setPointerCapture(event.pointerId);
    specPaintAt(event);
  });
  canvas.addEventListener("pointermove", (event) => { if (spec.painting) specPaintAt(event); });
  canvas.addEventListener("pointercancel", () => { spec.painting = false; });
  canvas.addEventListener("pointerup", () => {
    spec.painting = false;
    if (!spec.stroked) return;
    spec.stroked = false;
    if (document.getElementById("spec-auto").checked) reoptimiseSpecular(performance.now());
  });
}

// A float32 (height, width) array as a .npy file (format 1.0, little-endian, C order).
function specNpy(values, height, width) {
  let header = `{'descr': '<f4', 'fortran_order': False, 'shape': (${height}, ${width}), }`;
  header += " ".repeat((64 - ((10 + header.length + 1) % 64)) % 64) + "\n";
  const bytes = new Uint8Array(10 + header.length + values.byteLength);
  bytes.set([0x93, 0x4e, 0x55, 0x4d, 0x50, 0x59, 1, 0]);  // \x93NUMPY, version 1.0
  new DataView(bytes.buffer).setUint16(8, header.length, true);
  for (let i = 0; i < header.length; i++) bytes[10 + i] = header.charCodeAt(i);
  bytes.set(new Uint8Array(values.buffer, values.byteOffset, values.byteLength), 10 + header.length);
  return bytes;
}

async function specUpload(map, name) {
  let response;
  try {
    response = await fetch(`/api/uploads?name=${encodeURIComponent(name)}`, {
      method: "POST", headers: { "Content-Type": "application/octet-stream" },
      body: specNpy(map, spec.height, spec.width) });
  } catch (exc) {
    throw new ApiError("the workbench server does not answer (/api/uploads): is vergence serve still running?");
  }
  const data = await response.json().catch(() => null);
  if (!response.ok) throw new ApiError(data && data.error ? data.error : `/api/uploads: HTTP ${response.status}`);
  return data.id;
}

// Re-optimise with the painted maps. strokeStart: the time the stroke ended (performance.now()), or null for the
// button; a stroke that ends while one runs is answered once it is done, with every map painted by then.
async function reoptimiseSpecular(strokeStart) {
  if (!spec.base) return;
  if (spec.running) { spec.again = true; return; }
  spec.running = true;
  try { await specReoptimiseOnce(strokeStart); } finally { spec.running = false; }
  if (spec.again) { spec.again = false; await reoptimiseSpecular(null); }
}

async function specReoptimiseOnce(strokeStart) {
  const weightMaps = [];
  try {
    for (const [key, map] of spec.maps) {
      if (map.every((w) => w === 1)) continue;
      const [layer, term] = key.split("|");
      const upload = await specUpload(map, `layer${layer}-${term || "all"}.npy`);
      weightMaps.push({ layer: Number(layer), ...(term ? { term } : {}), upload });
    }
  } catch (exc) {
    showError(exc.message);
    document.body.dataset.state = "error";
    return;
  }
  const body = { job: spec.base, weights: specWeights(), variant: document.getElementById("spec-variant").value,
    weight_maps: weightMaps };
  const status = await specJob("specular-reoptimise", body, "spec-reopt-message");
  if (status) {
    await showSpecular(status.id, status.result);
    const s = status.result.seconds;
    let text = `re-optimised with ${weightMaps.length} painted map(s): solve ${fmt(s.plan_solve, 2)} s, `
      + `render ${fmt(s.final_render ?? 0, 2)} s${status.cached ? " (cached)" : ""}`;
    if (strokeStart !== null) {
      const ms = performance.now() - strokeStart;
      spec.strokeMs.push(ms);
      document.getElementById("spec-result").dataset.strokeMs = spec.strokeMs.map((v) => v.toFixed(1)).join(",");
      text += `; stroke to new image ${(ms / 1000).toFixed(2)} s`;
    }
    document.getElementById("spec-reopt-message").textContent = text;
    document.body.dataset.state = "ready";
  }
}

// The shown result's comfort overlay (disparity_after.npy: (N, H, W) float32 arcmin, NaN: no match), loaded once.
async function specLoadOverlay(id) {
  if (spec.overlay && spec.overlay.id === id) return;
  const npy = await ovFetchNpy(id, "disparity_after.npy", 3);
  spec.overlay = { id, n: npy.shape[0], height: npy.shape[1], width: npy.shape[2], data: npy.data };
}

// Tint the chosen layer's pixels outside the comfort zone after the latest solve (when the box is ticked) and
// say how many there are.
function specOutside(out) {
  const note = document.getElementById("spec-outside");
  const o = spec.overlay;
  const layer = Number(document.getElementById("spec-layer").value);
  if (!o || !spec.report || !layer || o.width !== spec.width || o.height !== spec.height) {
    note.textContent = "";
    return;
  }
  const [lo, hi] = spec.report.comfort_zone_arcmin;
  const plane = o.data.subarray((layer - 1) * o.width * o.height, layer * o.width * o.height);
  const show = document.getElementById("spec-overlay").checked;
  const [r, g, b, a] = SPEC_OUTSIDE_RGBA;
  let matched = 0;
  let outside = 0;
  for (let i = 0; i < plane.length; i++) {
    const d = plane[i];
    if (Number.isNaN(d)) continue;
    matched++;
    if (d >= lo && d <= hi) continue;
    outside++;
    if (!show) continue;
    out.data[4 * i] += (r - out.data[4 * i]) * a;
    out.data[4 * i + 1] += (g - out.data[4 * i + 1]) * a;
    out.data[4 * i + 2] += (b - out.data[4 * i + 2]) * a;
  }
  note.textContent = `layer ${layer} after the latest solve: ${outside} of ${matched} matched px`
    + ` outside the comfort zone [${lo}′, ${hi}′]${show && outside ? " (magenta)" : ""}`;
  note.dataset.outside = String(outside);
  note.dataset.job = o.id;
}

// ---------------------------------------------------------------- the result
function specCell(row, value, text, testid) {
  const td = row.insertCell();
  td.textContent = text;
  if (value !== undefined) td.dataset.value = value === null ? "" : String(value);
  if (testid) td.dataset.testid = testid;
  return td;
}

function specShare(v) { return v === null || v === undefined ? "—" : `${(100 * v).toFixed(1)} %`; }

// Show a result: the new optimised anaglyph and the comfort overlay first (a re-optimisation keeps the base job's
// other three methods: they do not change), then the tables; the sheets are drawn for the base job, and for a
// re-optimisation when asked (its sheets are pending on the server until then).
async function showSpecular(id, report) {
  spec.shown = id;
  spec.report = report;
  const src = (method) => jobFile(method === "optimised" ? id : spec.base, `${method}_anaglyph.png`);
  const row = document.getElementById("spec-anaglyphs");
  row.replaceChildren(...SPEC_METHODS.map(([method, label]) => {
    const fig = document.createElement("figure");
    const img = document.createElement("img");
    img.src = src(method);
    img.alt = `${label} anaglyph`;
    img.dataset.testid = `spec-anaglyph-${method}`;
    const caption = document.createElement("figcaption");
    caption.textContent = label;
    fig.append(img, caption);
    return fig;
  }));
  const latest = document.getElementById("spec-latest");
  latest.src = src("optimised");
  try {
    await Promise.all([latest.decode(), specLoadOverlay(id)]);
  } catch (exc) {
    showError(exc.message || "the new anaglyph cannot be loaded");
  }
  specDraw();
  specLoadOverlays(id).catch(specOverlaysError);  // the heat map and histogram (specular_overlays.js)
  latest.dataset.job = id;
  document.getElementById("spec-latest-caption").textContent = id === spec.base
    ? "optimised anaglyph (the first run)" : "optimised anaglyph (the latest re-optimisation)";
  specSheets(id, id === spec.base);
  const layers = document.querySelector("#spec-layers tbody");
  layers.replaceChildren();
  for (const layer of report.layers) {
    const tr = layers.insertRow();
    tr.dataset.layer = layer.layer;
    specCell(tr, undefined, `${layer.layer} · ${layer.name}`);
    specCell(tr, layer.pixels, String(layer.pixels), `spec-pixels-${layer.layer}`);
    specCell(tr, layer.inside_share_before, specShare(layer.inside_share_before), `spec-inside-before-${layer.layer}`);
    specCell(tr, layer.inside_share_after, specShare(layer.inside_share_after), `spec-inside-after-${layer.layer}`);
    specCell(tr, layer.comfort_share_before, specShare(layer.comfort_share_before),
      `spec-comfort-before-${layer.layer}`);
    specCell(tr, layer.comfort_share_after, specShare(layer.comfort_share_after), `spec-comfort-after-${layer.layer}`);
    specCell(tr, layer.matched_before, specShare(layer.matched_before), `spec-matched-before-${layer.layer}`);
    specCell(tr, layer.matched_after, specShare(layer.matched_after), `spec-matched-after-${layer.layer}`);
  }
  const d = report.display;
  document.getElementById("spec-display-line").textContent = d
    ? `${d.name ?? "display"}, fit ${d.fit}: ` + `${d.arcmin_per_px.toFixed(2)} arcmin per image pixel; `
      + report.warnings.map((w) => `warning: ${w}`).join("; ")
    : "";
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
  result.dataset.base = spec.base;
  result.hidden = false;
}

// The analysis sheets of job id as thumbnails (click: drawn at full size below, labelled), or, when not drawn
// yet (draw false: a re-optimisation's sheets are pending on the server), a button that asks for them.
function specSheets(id, draw) {
  const sheets = document.getElementById("spec-sheets");
  const button = document.getElementById("spec-draw-sheets");
  const note = document.getElementById("spec-sheets-note");
  const view = document.getElementById("spec-sheet-view");
  if (!draw) {
    sheets.replaceChildren();
    view.hidden = true;
    view.removeAttribute("src");  // a sheet still loading for the previous result is not shown
    delete view.dataset.sheet;
    document.getElementById("spec-sheet-caption").textContent = "";
    button.hidden = false;
    note.textContent = "the analysis sheets of this re-optimisation are drawn when asked (a few seconds)";
    return;
  }
  button.hidden = true;
  note.textContent = "";
  sheets.replaceChildren(...SPEC_SHEETS.map((name) => {
    const thumb = document.createElement("button");
    thumb.type = "button";
    thumb.title = `${name}: click to draw it at full size below`;
    thumb.dataset.testid = `spec-thumb-${name.replace(".png", "")}`;
    const img = document.createElement("img");
    img.src = jobFile(id, name);
    img.alt = name;
    img.dataset.testid = `spec-sheet-${name.replace(".png", "")}`;
    thumb.append(img);
    thumb.addEventListener("click", () => specShowSheet(id, name));
    return thumb;
  }));
  specShowSheet(id, spec.sheet);
}

const SPEC_SHEET_TITLES = { "analysis_disparity.png": "per-layer disparity, before and after (arcmin)",
  "analysis_importance.png": "per-layer importance, before and after", "analysis_rivalry.png":
  "per-layer rivalry (ΔL*)², before and after", "offsets.png": "per-layer camera offsets y (1: physical)" };

async function specShowSheet(id, name) {
  spec.sheet = name;
  for (const thumb of document.querySelectorAll("#spec-sheets button")) {
    thumb.setAttribute("aria-pressed", String(thumb.dataset.testid === `spec-thumb-${name.replace(".png", "")}`));
  }
  const view = document.getElementById("spec-sheet-view");
  view.src = jobFile(id, name);
  view.alt = `${name}: ${SPEC_SHEET_TITLES[name]}`;
  try { await view.decode(); } catch (exc) { return; }
  if (view.src !== new URL(jobFile(id, name), location.href).href) return;  // another sheet or result meanwhile
  const room = view.parentElement.clientWidth || view.naturalWidth;
  view.style.width = `${Math.round(Math.min(room, SPEC_SHEET_ZOOM * view.naturalWidth))}px`;
  view.hidden = false;
  view.dataset.sheet = name;
  document.getElementById("spec-sheet-caption").textContent = `${name}: ${SPEC_SHEET_TITLES[name]}; `
    + "one row per layer, its number and name at the left";
}

registerPage("specular", initSpecular);
