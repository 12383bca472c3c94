"use strict";

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

registerPage("specular", initSpecular);
