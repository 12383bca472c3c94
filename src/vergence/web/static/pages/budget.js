// Page 1: display and budget (S0 §2) and the disparity mapping psi (S0 §6): POST /api/budget and
// POST /api/mapping (the twins of `vergence budget --json` and `vergence mapping --json`), GET /api/displays.
"use strict";

// ---------------------------------------------------------------- page 1: display and budget
const DENSE_SAMPLES = 120;  // depths sent to /api/budget for the curves (log-spaced over the scene)
const DEBOUNCE_MS = 200;
// The plots' vertical ranges: z' up to 4 viewing distances, roundness in [-1, 3]; beyond, the curves
// leave the frame (they blow up where the eyes turn parallel). The figures above show exact values.
const PERCEIVED_CAP = 4;
const ROUNDNESS_CLIP = [-1, 3];
// A farthest depth of infinity ("inf", "∞"): the curves are drawn out to this many times the nearest
// depth (a log axis has no infinity); psi itself is built for the scene out to infinity.
const FAR_PLOT_FACTOR = 1000;
// The page's names of the fields the API names in its messages (the mapping's reference rig is the
// page's rig): a snake_case name anywhere, a one-word name at the start of the message.
const FIELD_LABELS = { reference_baseline: "baseline b", baseline: "baseline b", convergence: "convergence distance H",
  window: "window W", focal_mm: "focal length F", sensor_mm: "sensor S", near: "nearest depth",
  far: "farthest depth", eye_separation: "eye separation", viewing_distance: "viewing distance",
  screen_width: "screen width", screen_pixels: "screen pixels" };

// An API message in the page's words.
function pageMessage(message) {
  const lead = /^([a-z]+)\b/.exec(message);
  const out = lead && FIELD_LABELS[lead[1]] ? FIELD_LABELS[lead[1]] + message.slice(lead[1].length) : message;
  return out.replace(/\b[a-z]+(?:_[a-z]+)+\b/g, (name) => FIELD_LABELS[name] || name);
}

// A depth field: a number, or infinity written "inf", "infinity" or "∞"; null when blank, NaN when unreadable.
function depthValue(text) {
  const t = text.trim().toLowerCase();
  if (t === "") return null;
  if (["inf", "+inf", "infinity", "∞"].includes(t)) return Infinity;
  return Number(t);
}

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
    const near = number("near"), given = depthValue(value("far"));
    const far = given === Infinity ? near * FAR_PLOT_FACTOR : given;
    if (!(near > 0 && far > near && Number.isFinite(far))) return [];
    const out = [];
    for (let i = 0; i < DENSE_SAMPLES; i++) {
      out.push(Number((near * (far / near) ** (i / (DENSE_SAMPLES - 1))).toPrecision(6)));
    }
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
    const far = depthValue(value("far"));
    if (far !== null) body.far = far === Infinity ? "inf" : far;
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
      atProbe.perceived_depth === null ? (atProbe.diverges ? "— (eyes diverge)" : "∞")
        : `${fmt(atProbe.perceived_depth)} m`);
    // Roundness means nothing where the eyes diverge (no fused point to be round)
    setFigure("roundness-at-probe", atProbe.diverges ? null : atProbe.roundness,
      atProbe.diverges ? "— (eyes diverge)" : undefined);
    // The exact depth the eyes start to diverge (S0 Eq. 2), not the first sampled depth past it
    const zDiv = result.divergence_depth;
    const inScene = zDiv !== null && dense.length > 0 && zDiv <= dense[dense.length - 1].depth;
    setFigure("divergence-depth", inScene ? zDiv : null,
      zDiv === null ? "never" : `beyond z = ${fmt(zDiv)} m` + (inScene ? "" : " (past the scene's depths)"));
    const list = document.getElementById("warnings");
    list.replaceChildren(...result.warnings.map((w) => Object.assign(document.createElement("li"),
      { textContent: w, title: w })));
    return { dense, divergence: inScene ? zDiv : null, probe, convergence,
      viewingDistance: number("viewing-distance") || 1 };
  }

  // A budget curve as [z, value] points, broken where the eyes start to diverge (the curve jumps there);
  // with ``convergedOnly`` the diverging part is left out (roundness has no meaning there).
  function budgetPoints(samples, key, convergedOnly = false) {
    const points = [];
    samples.forEach((s, i) => {
      if (i > 0 && samples[i - 1].diverges !== s.diverges) points.push([s.depth, null]);
      points.push([s.depth, convergedOnly && s.diverges ? null : s[key]]);
    });
    return points;
  }

  function drawAll(budget, mapping) {
    const { dense, divergence, probe, convergence, viewingDistance } = budget;
    const shade = divergence !== null ? { from: divergence, label: "eyes diverge" } : null;
    const vlines = [{ x: convergence, label: "H", cls: "h" }, { x: probe, label: "z", cls: "probe" }];
    const xrange = dense.length ? [dense[0].depth, dense[dense.length - 1].depth] : null;
    const mapped = mapping ? mapping.samples.filter((s) => s.depth !== null) : [];
    const common = { xlog: true, xrange, shade, vlines, xlabel: "scene depth z (m)" };
    drawPlot(document.getElementById("plot-perceived"), [
      { points: budgetPoints(dense, "perceived_depth"), cls: "budget", label: "budget" },
      // psi keeps z' finite: its whole curve sets the range (the budget's blows up, so it is clipped)
      ...(mapping ? [{ points: mapped.map((s) => [s.depth, s.perceived_depth]), cls: "psi", label: "psi",
        unclipped: true }] : []),
    ], { ...common, ylabel: "z′ (m)", yclip: [0, PERCEIVED_CAP * viewingDistance] });
    drawPlot(document.getElementById("plot-roundness"), [
      { points: budgetPoints(dense, "roundness", true), cls: "budget", label: "budget" },
      ...(mapping ? [{ points: mapped.map((s) => [s.depth, s.roundness]), cls: "psi", label: "psi" }] : []),
    ], { ...common, ylabel: "roundness ρ", yinclude: [0, 1], yclip: ROUNDNESS_CLIP });
    const psiSvg = document.getElementById("plot-psi");
    if (!mapping) {
      drawPlot(psiSvg, [], { empty: "add a constraint to build ψ" });
    } else {
      const ds = mapping.samples.map((s) => s.disparity);
      drawPlot(psiSvg, [
        { points: [[Math.min(...ds), Math.min(...ds)], [Math.max(...ds), Math.max(...ds)]], cls: "identity",
          label: "identity" },
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
      if (!dense.length) throw new ApiError("the scene's depths: enter 0 < nearest < farthest (farthest may be inf)");
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
      showError(pageMessage(exc.message));
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
      const input = Object.assign(document.createElement("input"),
        { type: "number", step: "any", name, value: v ?? "" });
      input.setAttribute("aria-label", name);
      input.dataset.field = name;
      td.append(input);
      return td;
    });
    const remove = Object.assign(document.createElement("button"),
      { type: "button", textContent: "Remove", className: "remove" });
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

  for (const button of document.querySelectorAll("#page-budget [data-copy]")) {
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

registerPage("budget", initBudget);
