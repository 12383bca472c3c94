"use strict";

// ---------------------------------------------------------------- page 2: 2D + depth to stereo (the `synthesize` job)
// The input (the built-in example, an image + depth, or a stereo pair) goes up as uploads (POST /api/uploads);
// two `synthesize` jobs (parameter sets A and B, same input) make the pair in every layout of vergence.display
// with the comfort figures. The page shows a chosen layout of A and B wiped against each other, the
// figures of both, the downloads and the equivalent `vergence` command lines. Nothing is computed here.
const ST_FIRST_LAYOUTS = ["anaglyph", "sbs", "cross-eyed", "tb", "rows", "columns", "half-sbs", "half-tb",
  "checkerboard"];
const stState = { uploads: {}, jobs: { a: null, b: null }, results: { a: null, b: null }, body: null,
  format: "anaglyph" };

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
    response = await fetch(`/api/uploads?name=${encodeURIComponent(file.name)}`, {
      method: "POST", headers: { "Content-Type": type }, body: file });
  } catch (exc) {
    throw new ApiError("the workbench server does not answer (/api/uploads): is vergence serve still running?");
  }
  const data = await response.json().catch(() => null);
  if (!response.ok) {
    throw new ApiError(data && data.error ? `${field}: ${data.error}` : `${field}: HTTP ${response.status}`);
  }
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
  return before + cliLine("synthesize", options)
    .replace("vergence synthesize", `vergence synthesize ${q(image)} ${q(depth)}`);
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
        throw new ApiError(status.state === "failed" ? `${set.toUpperCase()}: ${status.error}`
          : `${set.toUpperCase()}: ${status.state}`);
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
  const ordered = [...ST_FIRST_LAYOUTS.filter((l) => layouts.includes(l)),
    ...layouts.filter((l) => !ST_FIRST_LAYOUTS.includes(l))];
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
  // a stereo pair's own parallax as matched is offered beside A and B (the matching result)
  const ovSet = document.getElementById("st-ov-set");
  const input = ovSet.querySelector('option[value="input"]');
  input.hidden = input.disabled = stState.body.a.left === undefined;
  if (input.disabled && ovSet.value === "input") ovSet.value = "a";
  stLoadOverlays(ovSet.value).catch(stOverlaysError);
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
  for (const view of ["left", "right"]) {
    document.getElementById(`st-${view}-a`).href = jobFile(stState.jobs.a, `${view}.png`);
  }
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
  svg.append(el("rect", { x: x(a.zone_min_arcmin), y: 6, width: x(a.zone_max_arcmin) - x(a.zone_min_arcmin), height: 56,
    class: "st-zone" }));
  svg.append(el("line", { x1: x(0), x2: x(0), y1: 4, y2: 64, class: "grid" }));
  for (const [row, set, c] of [[0, "A", a], [1, "B", b]]) {
    const y = 14 + row * 26;
    svg.append(el("text", { x: left - 8, y: y + 10, "text-anchor": "end", class: "label" }, set));
    svg.append(el("rect", { x: x(c.min_arcmin), y, width: Math.max(1, x(c.max_arcmin) - x(c.min_arcmin)), height: 14,
      class: `st-range st-range-${set.toLowerCase()}${c.inside ? "" : " st-out"}`,
      "data-testid": `st-bar-${set.toLowerCase()}` }));
  }
  for (const t of niceTicks(lo, hi, 6).ticks) {
    if (t < lo || t > hi) continue;
    svg.append(el("line", { x1: x(t), x2: x(t), y1: 64, y2: 68, class: "frame" }));
    svg.append(el("text", { x: x(t), y: 80, "text-anchor": "middle" }, fmt(t, 3)));
  }
  svg.append(el("text", { x: (left + width - right) / 2, y: 96, "text-anchor": "middle", class: "label" },
    "vergence change, arcmin (negative: in front of the screen)"));
}

// The overlays of a result: stereo_overlays.js (stInitOverlays, stLoadOverlays).

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
  document.getElementById("st-cancel").addEventListener("click", () => {
    if (stState.running) cancelJob(stState.running);
  });
  document.getElementById("st-format").addEventListener("change", (event) => {
    stState.format = event.target.value;
    stShowFormat();
  });
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
