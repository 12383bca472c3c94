"use strict";

// ---------------------------------------------------------------- page 4: rig planner (S0 §5–6)
// A shot (docs/shots.md) edited in a form; POST /api/rigs/plan answers what `vergence rig plan --json` prints,
// drawn here from above (SVG) and listed; the `rig` job renders it small: the pair, the truth and the error.
// Presets: GET /api/rigs/shots. The page only gathers inputs and draws the API's answers.
const RIG_PLAN_DEBOUNCE_MS = 250;
let rigPresets = [];
let rigPlanSeq = 0;
let rigShown = null;  // {shot, plan} of the plan on screen
let rigJob = null;

const rigEl = (id) => document.getElementById(id);

async function initRigs() {
  document.body.dataset.state = "loading";
  try {
    // one after the other: the first request of a fresh server imports the renderer (two at once raced it)
    const shots = await api("/api/rigs/shots");
    const data = await api("/api/data");
    const displays = await api("/api/displays");
    rigPresets = shots.shots;
    const presets = rigEl("rig-preset");
    for (const p of rigPresets) presets.add(new Option(p.source === "data" ? `${p.name} (data folder)` : p.name, p.id));
    const scenes = rigEl("rig-scene");
    for (const e of data.scenes) scenes.add(new Option(e.name, e.format === "builtin" ? e.name : e.id));
    const display = rigEl("rig-display");
    for (const d of displays.displays) display.add(new Option(d.name, d.name));
    // each rig's own fields start from its first preset, so that switching the rig kind gives a plan at once
    for (const kind of ["tri", "quadri"]) {
      const p = rigPresets.find((s) => s.shot.rig === kind);
      if (p) rigFill(p.shot);
    }
    if (rigPresets.length) rigFill(rigPresets[0].shot);
    const later = debounce(rigPlan, RIG_PLAN_DEBOUNCE_MS);
    const changed = () => {
      document.body.dataset.state = "loading";
      rigEl("rig-results").classList.add("stale");
      // the render shown is of the settings as they were: dimmed until the next
      rigEl("rig-result").classList.add("stale");
      later();
    };
    const form = rigEl("rig-form");
    form.addEventListener("input", (ev) => { if (ev.target.id !== "rig-preset") changed(); });
    presets.addEventListener("change", () => {
      const p = rigPresets.find((s) => s.id === presets.value);
      if (p) rigFill(p.shot);
      changed();
    });
    rigEl("rig-kind").addEventListener("change", () => { rigToggle(); changed(); });
    display.addEventListener("change", () => { rigToggle(); changed(); });
    rigEl("rig-add-element").addEventListener("click", () => {
      rigElementRow({ name: "", point: [0, 0, 0] });
      changed();
    });
    rigEl("rig-add-constraint").addEventListener("click", () => { rigConstraintRow(""); changed(); });
    rigEl("rig-run").addEventListener("click", rigRender);
    rigEl("rig-cancel").addEventListener("click", () => { if (rigJob) cancelJob(rigJob); });
    await rigPlan();
  } catch (exc) {
    showError(exc.message);
    document.body.dataset.state = "error";
  }
}

// ---------------------------------------------------------------- the form <-> the shot's JSON
function rigSetNumber(id, value) { rigEl(id).value = value === null || value === undefined ? "" : String(value); }

function rigFill(shot) {
  rigEl("rig-kind").value = shot.rig;
  const scenes = rigEl("rig-scene");
  if (![...scenes.options].some((o) => o.value === shot.scene)) scenes.add(new Option(shot.scene, shot.scene));
  scenes.value = shot.scene;
  const display = rigEl("rig-display");
  if (typeof shot.display === "string") {
    display.value = shot.display;
  } else {
    display.value = "";
    rigSetNumber("rig-eye-separation", shot.display.eye_separation);
    rigSetNumber("rig-distance", shot.display.distance);
    rigSetNumber("rig-screen-width", shot.display.width);
    rigSetNumber("rig-resolution", shot.display.resolution);
  }
  const cam = shot.camera;
  const vectors = { position: cam.position, look_at: cam.look_at, up: cam.up || [0, 1, 0] };
  for (const input of document.querySelectorAll("#rig-form [data-vec]")) {
    input.value = String(vectors[input.dataset.vec][Number(input.dataset.i)]);
  }
  rigSetNumber("rig-fov", cam.fov_deg);
  rigSetNumber("rig-width", cam.width);
  rigSetNumber("rig-height", cam.height);
  if (shot.rig === "quadri") {
    rigSetNumber("rig-baseline", shot.baseline);
    rigSetNumber("rig-convergence", shot.convergence);
    rigSetNumber("rig-setback", shot.setback);
    rigEl("rig-elements").replaceChildren();
    for (const e of shot.elements) rigElementRow(e);
  } else {
    rigEl("rig-constraints").replaceChildren();
    for (const c of shot.constraints) rigConstraintRow(c);
    rigEl("rig-reference").value = shot.reference || "round";
    rigSetNumber("rig-near", shot.near);
    rigSetNumber("rig-far", shot.far);
  }
  rigToggle();
}

function rigToggle() {
  const kind = rigEl("rig-kind").value;
  for (const fs of document.querySelectorAll("#rig-form [data-rig]")) fs.hidden = fs.dataset.rig !== kind;
  const custom = rigEl("rig-display").value === "";
  for (const label of document.querySelectorAll("#rig-form [data-display]")) label.hidden = !custom;
  rigEl("rig-camera-legend").textContent = kind === "quadri"
    ? "Camera: the virtual rig's centre" : "Camera: the director's (left)";
  rigEl("rig-camera-hint").textContent = kind === "quadri"
    ? "Where no real camera can go; the real cameras stand the setback behind it."
    : "The left image, unchanged; the subject and background cameras stand to its right.";
}

function rigInput(attrs) {
  const input = document.createElement("input");
  Object.assign(input, attrs);
  return input;
}

function rigRemoveButton(row) {
  const b = Object.assign(document.createElement("button"), { type: "button", textContent: "×", title: "remove" });
  b.addEventListener("click", () => { row.remove(); rigEl("rig-form").dispatchEvent(new Event("input")); });
  return b;
}

function rigElementRow(element) {
  const tr = rigEl("rig-elements").insertRow();
  const n = rigEl("rig-elements").rows.length - 1;
  tr.insertCell().append(rigInput({ type: "text", value: element.name, className: "rig-name" }));
  element.point.forEach((v, i) => {
    const input = rigInput({ type: "number", step: "any", value: String(v) });
    input.dataset.testid = `rig-element-${n}-${"xyz"[i]}`;
    tr.insertCell().append(input);
  });
  tr.insertCell().append(rigRemoveButton(tr));
}

function rigConstraintRow(text) {
  const parts = {};
  for (const item of text.split(",")) {
    const [k, v] = item.split("=");
    if (k && v !== undefined) parts[k.trim()] = v.trim();
  }
  const tr = rigEl("rig-constraints").insertRow();
  const n = rigEl("rig-constraints").rows.length - 1;
  for (const key of ["z", "perceived", "roundness"]) {
    const input = rigInput({ type: "text", value: parts[key] || "", className: "rig-short" });
    input.dataset.key = key;
    input.dataset.testid = `rig-constraint-${n}-${key}`;
    tr.insertCell().append(input);
  }
  tr.insertCell().append(rigRemoveButton(tr));
}

function rigNumber(id) {
  const text = rigEl(id).value.trim();
  return text === "" ? null : Number(text);
}

// The shot as the form says it (docs/shots.md); the server checks it and says what is wrong.
function readRigShot() {
  const vec = (name) => [0, 1, 2].map((i) => {
    const text = document.querySelector(`#rig-form [data-vec="${name}"][data-i="${i}"]`).value.trim();
    return text === "" ? null : Number(text);
  });
  const displayName = rigEl("rig-display").value;
  let display = displayName;
  if (!displayName) {
    display = { eye_separation: rigNumber("rig-eye-separation"), distance: rigNumber("rig-distance"),
      width: rigNumber("rig-screen-width") };
    if (rigEl("rig-resolution").value.trim() !== "") display.resolution = rigNumber("rig-resolution");
  }
  const shot = {
    rig: rigEl("rig-kind").value, scene: rigEl("rig-scene").value, display,
    camera: { position: vec("position"), look_at: vec("look_at"), up: vec("up"), fov_deg: rigNumber("rig-fov"),
      width: rigNumber("rig-width"), height: rigNumber("rig-height") },
  };
  if (shot.rig === "quadri") {
    shot.baseline = rigNumber("rig-baseline");
    shot.convergence = rigNumber("rig-convergence");
    shot.setback = rigNumber("rig-setback");
    shot.elements = [...rigEl("rig-elements").rows].map((tr) => {
      const inputs = tr.querySelectorAll("input");
      return { name: inputs[0].value.trim(),
        point: [1, 2, 3].map((i) => (inputs[i].value.trim() === "" ? null : Number(inputs[i].value))) };
    });
  } else {
    shot.constraints = [...rigEl("rig-constraints").rows].map((tr) => {
      const get = (key) => tr.querySelector(`[data-key="${key}"]`).value.trim();
      return `z=${get("z")},perceived=${get("perceived")}` + (get("roundness") ? `,roundness=${get("roundness")}` : "");
    });
    shot.reference = rigEl("rig-reference").value;
    if (rigEl("rig-near").value.trim() !== "") shot.near = rigNumber("rig-near");
    shot.far = rigNumber("rig-far");
  }
  return shot;
}

// ---------------------------------------------------------------- the plan
async function rigPlan() {
  const seq = ++rigPlanSeq;
  const shot = readRigShot();
  const text = JSON.stringify(shot, null, 2);
  rigEl("rig-shot-json").textContent = text;
  rigEl("rig-download").href = `data:application/json;charset=utf-8,${encodeURIComponent(text + "\n")}`;
  document.body.dataset.state = "loading";
  try {
    const plan = await api("/api/rigs/plan", shot);
    if (seq !== rigPlanSeq) return;
    showError(null);
    rigShown = { shot, plan };
    rigDrawPlan(shot, plan);
    rigEl("rig-results").classList.remove("stale");
    rigEl("rig-run").disabled = false;
    document.body.dataset.state = "ready";
  } catch (exc) {
    if (seq !== rigPlanSeq) return;
    showError(exc.message);
    rigEl("rig-run").disabled = true;
    document.body.dataset.state = "error";
  }
}

function rigFigure(list, label, value, text, testid) {
  const div = document.createElement("div");
  const dt = document.createElement("dt");
  dt.innerHTML = label;
  const dd = document.createElement("dd");
  dd.textContent = text;
  dd.dataset.value = typeof value === "number" || typeof value === "boolean" ? String(value) : "";
  dd.dataset.testid = testid;
  div.append(dt, dd);
  list.append(div);
}

function rigDrawPlan(shot, plan) {
  const figures = rigEl("rig-figures");
  figures.replaceChildren();
  rigFigure(figures, "Real cameras", plan.cameras.length, String(plan.cameras.length), "rig-fig-count");
  if (plan.rig === "quadri") {
    rigFigure(figures, "Setback s", plan.setback, `${fmt(plan.setback)} m`, "rig-fig-setback");
    for (const row of plan.cameras.filter((r) => r.eye === "left")) {
      rigFigure(figures, `b<sub>${row.element}</sub> (S0 Eq. 10)`, row.baseline, `${fmt(row.baseline)} m`,
        `rig-fig-baseline-${row.element}`);
      rigFigure(figures, `fx ratio ${row.element}`, row.fx_ratio, `× ${fmt(row.fx_ratio)}`,
        `rig-fig-ratio-${row.element}`);
    }
  } else {
    for (const row of plan.cameras.slice(1)) {
      rigFigure(figures, `b<sub>${row.name}</sub>`, row.baseline, `${fmt(row.baseline)} m`,
        `rig-fig-baseline-${row.name}`);
    }
    const ref = plan.reference;
    rigFigure(figures, "ψ reference b<sub>r</sub>", ref.baseline, `${fmt(ref.baseline)} m`, "rig-fig-ref-baseline");
    rigFigure(figures, "Convergence H", ref.convergence, `${fmt(ref.convergence)} m`, "rig-fig-ref-convergence");
    rigFigure(figures, "Window W", ref.window, `${fmt(ref.window)} m`, "rig-fig-ref-window");
    rigFigure(figures, "ψ monotone", plan.monotone, plan.monotone ? "yes" : "no", "rig-fig-monotone");
    rigFigure(figures, "ψ diverges", plan.diverges, plan.diverges ? "yes" : "no", "rig-fig-diverges");
  }
  const body = document.querySelector("#rig-cameras tbody");
  body.replaceChildren();
  for (const row of plan.cameras) {
    const tr = body.insertRow();
    tr.dataset.name = row.name;
    const cell = (value, text, key) => {
      const td = tr.insertCell();
      td.textContent = text;
      if (key) { td.dataset.key = key; td.dataset.value = value === null ? "" : String(value); }
    };
    cell(null, row.name);
    cell(null, row.element);
    cell(null, row.eye);
    cell(row.camera.center.join(" "), row.camera.center.map((v) => v.toFixed(2)).join(" "), "center");
    cell(row.fx, fmt(row.fx), "fx");
    cell(row.fx_ratio, fmt(row.fx_ratio), "fx_ratio");
    cell(row.baseline, row.baseline === null ? "—" : fmt(row.baseline), "baseline");
  }
  rigDrawTop(shot, plan);
}

// The rig from above (rigDrawTop): rigs_top.js.

// ---------------------------------------------------------------- the render job
function rigBusy(busy) {
  rigEl("rig-run").disabled = busy;
  rigEl("rig-cancel").disabled = true;
}

function rigRenderBody() {
  const num = (id) => Number(rigEl(id).value);
  return { shot: readRigShot(), width: num("rig-render-width"), weights: rigEl("rig-weights").value,
    samples: num("rig-samples"), supersample: num("rig-supersample") };
}

async function rigRender() {
  showError(null);
  rigEl("rig-result").hidden = true;
  document.body.dataset.state = "loading";
  rigBusy(true);
  rigJob = null;
  const progress = rigEl("rig-progress"), message = rigEl("rig-message");
  let status;
  try {
    status = await runJob("rig", rigRenderBody(), {
      onStart: (id) => { rigJob = id; rigEl("rig-cancel").disabled = false; },
      onProgress: (s) => {
        progress.value = s.progress || 0;
        message.textContent = `${Math.round(100 * (s.progress || 0))} % ${s.message || ""}`;
      },
    });
  } catch (exc) {
    showError(exc.message);
    rigBusy(false);
    document.body.dataset.state = "error";
    return;
  }
  rigBusy(false);
  if (!jobDone(status, message)) return;
  progress.value = 1;
  message.textContent = status.cached ? "done (cached)" : "done";
  rigShowResult(status.id, status.result, status.files);
  rigEl("rig-result").classList.remove("stale");
  document.body.dataset.state = "ready";
}

function rigImage(id, name, caption) {
  const fig = document.createElement("figure");
  const img = document.createElement("img");
  img.src = jobFile(id, name);
  img.alt = caption;
  img.dataset.testid = `rig-img-${name.replace(".png", "")}`;
  const cap = document.createElement("figcaption");
  cap.textContent = caption;
  fig.append(img, cap);
  return fig;
}

function rigRow(title, figures) {
  const wrap = document.createElement("div");
  const h = document.createElement("h4");
  h.textContent = title;
  const row = document.createElement("div");
  row.className = "rig-row";
  row.append(...figures);
  wrap.append(h, row);
  return wrap;
}

function rigShowResult(id, result, files) {
  const body = document.querySelector("#rig-metrics tbody");
  body.replaceChildren();
  for (const [method, eyes] of Object.entries(result.methods)) {
    for (const [eye, m] of Object.entries(eyes)) {
      const tr = body.insertRow();
      tr.dataset.method = method;
      tr.dataset.eye = eye;
      const cell = (value, text, key) => {
        const td = tr.insertCell();
        td.textContent = text;
        if (key) { td.dataset.key = key; td.dataset.value = value === null ? "" : String(value); }
      };
      cell(null, method);
      cell(null, eye);
      cell(m.psnr, m.psnr === null ? (m.note || "∞ (identical)") : m.psnr.toFixed(2), "psnr");
      cell(m.dssim, m.dssim === null ? "—" : m.dssim.toExponential(2), "dssim");
      const filled = m.psnr_filled === undefined ? null : m.psnr_filled;
      cell(filled, filled === null ? "—" : filled.toFixed(2), "psnr_filled");
      cell(m.coverage, `${(100 * m.coverage).toFixed(1)} %`, "coverage");
    }
  }
  const has = (name) => files.includes(name);
  const rows = [];
  for (const method of Object.keys(result.methods)) {
    const label = method === "ulr" ? "ULR" : "Bayesian";
    rows.push(rigRow(`Synthesised pair, ${label} (${result.size[0]}×${result.size[1]})`, [
      rigImage(id, `${method}_left.png`, result.rig === "tri" ? "left: the director's image" : "left eye"),
      rigImage(id, `${method}_right.png`, "right eye"),
      rigImage(id, `${method}_anaglyph.png`, "Dubois anaglyph")]));
    const errors = ["left", "right"].filter((eye) => has(`${method}_error_${eye}.png`))
      .map((eye) => rigImage(id, `${method}_error_${eye}.png`,
        `${eye}: |synthesised − truth| × 4; blue: no source sees it`));
    rows.push(rigRow(`Error, ${label}`, errors));
  }
  rows.push(rigRow(
    result.rig === "tri" ? "Truth (right: the curved-ray truth of S0 §6)" : "Truth (the virtual eyes ray-traced)",
    [rigImage(id, "truth_left.png", "left"), rigImage(id, "truth_right.png", "right")]));
  rigEl("rig-images").replaceChildren(...rows);
  rigEl("rig-sources").replaceChildren(...result.cameras.map((name) => rigImage(id, `camera_${name}.png`, name)));
  const vr = rigEl("rig-vr");
  vr.replaceChildren();
  const first = Object.keys(result.methods)[0];
  offerVR(vr, () => ({ left: jobFile(id, `${first}_left.png`), right: jobFile(id, `${first}_right.png`) }));
  const box = rigEl("rig-result");
  box.dataset.job = id;
  box.hidden = false;
}

registerPage("rigs", initRigs);
