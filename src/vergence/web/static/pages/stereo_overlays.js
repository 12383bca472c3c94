"use strict";

// ---------------------------------------------------------------- page 2's overlays (stereo.js's results)
// docs/workbench.md, "Overlays".
// For one result (A or B): its parallax map P = x_r - x_l (parallax.npy of the job: px of the pair, positive
// behind the screen, NaN unknown) and GET /api/stereo/{id}/overlay (the comfort zone, the divergence limit and
// the colour scale converted to px of the pair by the library, the stereo-window rule of vergence.video).
// The pair is drawn here as a red-cyan anaglyph, shifted by the horizontal image translation (HIT) s: the
// left view moves -s/2 px, the right view +s/2 px, so every parallax becomes P + s (no re-synthesis;
// uncovered columns are black). The heat map, the histogram, its shares and the window check follow s.
// The heat map's colour scale is +-scale arcmin (in px of the pair, from the server); its colours, the counts
// and the histogram are overlays.js's.
const stOv = { set: null, geo: null, P: null, W: 0, H: 0, views: null, bins: null, shift: 0, token: 0 };

// Loads the overlays of result `set` (its parallax map, the geometry, both views), then draws them. Set "a" or
// "b": that result's synthesized pair; "input": a stereo pair as it was matched (the matching result: its parallax
// -d and its views, written by job A; the same in B).
async function stLoadOverlays(set) {
  const token = ++stOv.token;
  const id = stState.jobs[set === "input" ? "a" : set];
  if (!id) return;  // nothing synthesized yet
  const scale = document.getElementById("st-heat-scale").value;
  document.getElementById("st-overlays").dataset.state = "loading";
  const of = set === "input" ? "input" : "result";
  const geo = await api(`/api/stereo/${id}/overlay?scale_arcmin=${encodeURIComponent(scale)}&of=${of}`);
  const [npy, left, right] = await Promise.all([
    ovFetchNpy(id, geo.parallax), ovImage(jobFile(id, geo.views[0])), ovImage(jobFile(id, geo.views[1])),
  ]);
  if (token !== stOv.token) return;  // a later choice won
  Object.assign(stOv, { set, geo, P: npy.data, H: npy.shape[0], W: npy.shape[1], views: { left, right } });
  stOv.bins = ovBins(stOv.P);  // at s = 0; the bin width stays as s moves
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

function stOvState() {
  const s = stOv.shift;
  const { P, W, H, geo } = stOv;
  const state = ovCount(P, { shift: s, binWidth: stOv.bins.width, zone: geo.zone_px, divergence: geo.divergence_px });
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
    edges[edge] = { share, violation, cue, rows: [first, last],
      width: violation && cue > geo.window.min_px ? Math.ceil(cue) : 0 };
  }
  return { ...state, edges };
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
  const canvas = document.getElementById("st-heat-canvas");
  ovDrawHeat(canvas, stOv.P, stOv.W, stOv.H, stOv.geo.scale.px, stOv.shift);
  canvas.hidden = !document.getElementById("st-heat").checked;
  canvas.style.opacity = String(Number(document.getElementById("st-heat-opacity").value) / 100);
}

// The colour bar: ticks at the arcmin the server converted (px of the pair below), the zone's limits marked.
function stHeatBar() {
  const { scale, zone_px: zone, display } = stOv.geo;
  ovHeatBar(document.getElementById("st-heat-bar"), {
    range: scale.px, marks: zone, units: ["arcmin", "px"],
    ticks: scale.ticks.map((t) => ({ value: t.px, label: `${fmt(t.arcmin, 3)}′`, sub: `${fmt(t.px, 2)}`,
      attrs: { "data-arcmin": String(t.arcmin) } })),
    caption: `vergence on ${display} · red: in front of the screen, blue: behind · green: comfort zone`,
  });
}

function stDrawHistogram(state) {
  const { geo, bins } = stOv;
  const reach = Number(document.getElementById("st-hit").max);
  const svg = document.getElementById("st-hist");
  const divOn = ovDrawHistogram(svg, state, {
    binWidth: bins.width, zone: geo.zone_px, divergence: geo.divergence_px, span: [bins.lo - reach, bins.hi + reach],
    xlabel: "parallax P + s, px of the pair (negative: in front of the screen)",
    zoneLabel: `comfort zone ±${fmt(geo.zone_arcmin[1], 3)}′`,
  });
  svg.dataset.shift = String(stOv.shift);
  ovShare(document.getElementById("st-share-zone"), state.outside, state.known);
  ovShare(document.getElementById("st-share-div"), state.diverging, state.known,
    `; the limit at ${fmt(geo.divergence_px, 3)} px${divOn ? "" : ", off the plot"}`);
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
      ? `${edge} edge: stereo-window violation, rows ${e.rows[0]}–${e.rows[1]} ` +
        `(${band}, ≥ ${100 * geo.window.share} %): ` +
        `a floating window of ${e.width} px masks it`
      : `${edge} edge: no violation (${band})`;
    li.className = e.violation ? (mask[edge] ? "st-masked" : "st-violation") : "";
    return li;
  }));
  const note = document.getElementById("st-float-note");
  const applied = ["left", "right"].filter((e) => mask[e] > 0)
    .map((e) => `${e} edge of the ${e} view: ${mask[e]} px black ` +
      `(the window's edge ${mask[e]} px in front of the screen)`);
  note.textContent = !floating ? "Floating window off."
    : applied.length ? `Floating window applied in the shown pair: ${applied.join("; ")}.`
    : "Floating window on: no edge needs it.";
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
  p.textContent = `Vertical disparity (rectify --check's measure, median |y_r − y_l| of ${r.matches} ` +
    `SIFT + RANSAC matches): ${fmt(r.median_abs_dy_px, 3)} px of the pair ` +
    `(90th percentile ${fmt(r.p90_abs_dy_px, 3)} px; ${fmt(display, 3)} px on ${stOv.geo.display})` +
    (r.above ? ` — above ${r.threshold_px} px: rectify the pair (vergence rectify) before matching`
      : ` — below ${r.threshold_px} px`);
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
    if (set === stOv.set && shift !== 0) {
      parts.push(`HIT ${signed(shift)} px (left view ${signed(-shift / 2)} px, right view ${signed(shift / 2)} px)`);
    }
    if (set === stOv.set && (mask.left || mask.right)) {
      parts.push(`floating window: left ${mask.left} px, right ${mask.right} px`);
    }
    field.value = parts.length
      ? `${base}  # shown on the page with ${parts.join(", ")}: not applied by this command` : base;
  }
  const link = document.getElementById("st-save-shown");
  const { shift, mask } = stOv.applied;
  const tag = `${stOv.set}_anaglyph_hit${shift >= 0 ? "+" : ""}${shift}px` +
    `${mask.left || mask.right ? `_window-l${mask.left}-r${mask.right}` : ""}`;
  link.download = `${tag}.png`;
  const shown = stOv.set === "input" ? "the stereo pair as matched" : stOv.set.toUpperCase();
  link.textContent = `Download the shown pair (${shown}, red-cyan anaglyph at 2×, ` +
    `HIT ${shift >= 0 ? "+" : ""}${shift} px` +
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
  document.getElementById("st-ov-set").addEventListener("change",
    (ev) => stLoadOverlays(ev.target.value).catch(stOverlaysError));
  document.getElementById("st-heat-scale").addEventListener("change",
    () => stLoadOverlays(stOv.set).catch(stOverlaysError));
  document.getElementById("st-heat").addEventListener("change", redraw);
  document.getElementById("st-heat-opacity").addEventListener("input", () => {
    document.getElementById("st-heat-canvas").style.opacity =
      String(Number(document.getElementById("st-heat-opacity").value) / 100);
  });
  document.getElementById("st-hit").addEventListener("input", (ev) => {
    stOv.shift = Number(ev.target.value);
    redraw();
  });
  document.getElementById("st-hit-reset").addEventListener("click", () => {
    stOv.shift = 0;
    document.getElementById("st-hit").value = "0";
    redraw();
  });
  document.getElementById("st-float").addEventListener("change", redraw);
  document.getElementById("st-save-shown").addEventListener("click", (ev) => {
    const link = ev.currentTarget;
    link.href = document.getElementById("st-pair-canvas").toDataURL("image/png");
  });
}
