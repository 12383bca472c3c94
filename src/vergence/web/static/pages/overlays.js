"use strict";

// ---------------------------------------------------------------- overlays shared by the pages
// (docs/workbench.md, "Overlays")
// What a stereographer's overlays draw from a disparity map the server wrote (an NPY file of a job): a heat map
// over the image, its colour bar, and a histogram against the display's comfort zone and divergence limit with
// the plain shares outside them. The numbers (the map, the zone, the limit, the colour scale's ticks) come from
// the server; this file only counts and draws. Used by page 2 (stereo.js: parallax in px of the pair, shifted by
// the HIT slider) and page 5 (specular.js: the layers' disparity in arcmin). Loaded before those pages' scripts.
//
// The colour map: t in [0, 1] from a value v and a range [lo, hi] with lo < 0 < hi (0: lo, in front of the
// screen; 0.5: the screen; 1: hi, behind), linear on each side of 0 and clamped; RGB interpolated between
// OV_HEAT_STOPS (ColorBrewer's RdBu, red in front).
const OV_HEAT_STOPS = [[0, [178, 24, 43]], [0.25, [239, 138, 98]], [0.5, [247, 247, 247]], [0.75, [103, 169, 207]],
  [1, [33, 102, 172]]];
const OV_HIST_BINS = 40;  // about this many bins over a map's range; their width stays as a shift moves the values
const OV_BIN_STEPS = [1, 2, 2.5, 5];

// A float32 NPY file (numpy's format 1.0-3.0, little-endian, C order) of `ndim` dimensions as {shape, data}.
function ovParseNpy(buffer, name, ndim = 2) {
  const bytes = new Uint8Array(buffer);
  if (bytes[0] !== 0x93 || String.fromCharCode(...bytes.slice(1, 6)) !== "NUMPY") {
    throw new ApiError(`${name} is not an NPY file`);
  }
  const view = new DataView(buffer);
  const major = bytes[6];
  const headerLen = major === 1 ? view.getUint16(8, true) : view.getUint32(8, true);
  const start = major === 1 ? 10 : 12;
  const header = new TextDecoder().decode(bytes.slice(start, start + headerLen));
  if (!/'descr':\s*'<f4'/.test(header) || /'fortran_order':\s*True/.test(header)) {
    throw new ApiError(`${name}: expected little-endian float32 in C order; got ${header.trim()}`);
  }
  const dims = header.match(/'shape':\s*\(([\d,\s]*)\)/);
  const shape = dims ? dims[1].split(",").map((s) => s.trim()).filter((s) => s !== "").map(Number) : [];
  if (shape.length !== ndim) throw new ApiError(`${name}: expected a ${ndim}-D array; got ${header.trim()}`);
  const n = shape.reduce((a, b) => a * b, 1);
  return { shape, data: new Float32Array(buffer.slice(start + headerLen, start + headerLen + 4 * n)) };
}

// Fetches a job's NPY file and parses it.
async function ovFetchNpy(id, name, ndim = 2) {
  let response;
  try { response = await fetch(jobFile(id, name)); } catch (exc) {
    throw new ApiError(`the workbench server does not answer (${name}): is vergence serve still running?`);
  }
  if (!response.ok) throw new ApiError(`${name}: HTTP ${response.status}`);
  return ovParseNpy(await response.arrayBuffer(), name, ndim);
}

function ovImage(url) {
  return new Promise((resolve, reject) => {
    const img = new Image();
    img.onload = () => resolve(img);
    img.onerror = () => reject(new ApiError(`cannot load ${url}`));
    img.src = url;
  });
}

function ovHeatT(v, range) {
  const [lo, hi] = range;
  return v <= 0 ? 0.5 * (1 - Math.min(v / lo, 1)) : 0.5 + 0.5 * Math.min(v / hi, 1);
}

function ovHeatColour(t) {
  for (let i = 1; i < OV_HEAT_STOPS.length; i++) {
    const [t1, c1] = OV_HEAT_STOPS[i];
    if (t <= t1 || i === OV_HEAT_STOPS.length - 1) {
      const [t0, c0] = OV_HEAT_STOPS[i - 1];
      const f = Math.max(0, Math.min(1, (t - t0) / (t1 - t0)));
      return c0.map((c, k) => Math.round(c + f * (c1[k] - c)));
    }
  }
  return OV_HEAT_STOPS[0][1];
}

// The heat map of `values` (W x H, row-major; NaN unknown: transparent) plus `shift` on `canvas`, one canvas
// pixel per value.
function ovDrawHeat(canvas, values, W, H, range, shift = 0) {
  canvas.width = W; canvas.height = H;
  const ctx = canvas.getContext("2d");
  const image = ctx.createImageData(W, H);
  for (let i = 0; i < W * H; i++) {
    if (!Number.isFinite(values[i])) continue;
    const [r, g, b] = ovHeatColour(ovHeatT(values[i] + shift, range));
    image.data.set([r, g, b, 255], 4 * i);
  }
  ctx.putImageData(image, 0, 0);
}

// The colour bar: t from 0 to 1 left to right. opts: range (the heat map's), ticks [{value, label, sub, attrs}]
// (label on the first row, sub on the second when opts.units[1] is given), marks (values: the zone's limits),
// units ([first row, second row]), caption.
function ovHeatBar(svg, opts) {
  svg.replaceChildren();
  const { range, ticks, marks = [], units, caption } = opts;
  const left = 76, right = 24, width = 560, n = 120;
  const x = (t) => left + t * (width - left - right);
  for (let i = 0; i < n; i++) {
    const [r, g, b] = ovHeatColour((i + 0.5) / n);
    svg.append(el("rect", { x: x(i / n), y: 4, width: (width - left - right) / n + 0.5, height: 14,
      fill: `rgb(${r},${g},${b})` }));
  }
  svg.append(el("rect", { x: left, y: 4, width: width - left - right, height: 14, class: "frame" }));
  for (const z of marks) svg.append(el("line", { x1: x(ovHeatT(z, range)), x2: x(ovHeatT(z, range)), y1: 1, y2: 21,
    class: "st-zone-mark" }));
  for (const tick of ticks) {
    const tx = x(ovHeatT(tick.value, range));
    svg.append(el("line", { x1: tx, x2: tx, y1: 18, y2: 22, class: "frame" }));
    svg.append(el("text", { x: tx, y: 33, "text-anchor": "middle", ...(tick.attrs || {}) }, tick.label));
    if (units[1]) svg.append(el("text", { x: tx, y: 45, "text-anchor": "middle", class: "st-px" }, tick.sub));
  }
  svg.append(el("text", { x: left - 22, y: 33, "text-anchor": "end", class: "label" }, units[0]));
  if (units[1]) svg.append(el("text", { x: left - 22, y: 45, "text-anchor": "end", class: "label" }, units[1]));
  svg.append(el("text", { x: (left + width - right) / 2, y: units[1] ? 57 : 45, "text-anchor": "middle",
    class: "label" }, caption));
}

// The histogram's bins for `values` (NaN skipped): a width from OV_BIN_STEPS x 10^k giving about OV_HIST_BINS
// over their range (at least `minSpan`), edges on its multiples. With `trim` (a share, e.g. 0.01) the width is
// set by the range between the trim and 1 - trim quantiles, so that a few far pixels do not make every bin
// coarse (they keep their own bins); lo and hi stay the whole range.
function ovBins(values, minSpan = 0.5, trim = 0) {
  let lo = Infinity, hi = -Infinity;
  for (const v of values) if (Number.isFinite(v)) { if (v < lo) lo = v; if (v > hi) hi = v; }
  if (!(hi >= lo)) { lo = 0; hi = 0; }
  let [qlo, qhi] = [lo, hi];
  if (trim > 0 && hi > lo) {
    const known = Float64Array.from(values).filter(Number.isFinite).sort();
    const at = (q) => known[Math.min(known.length - 1, Math.floor(q * (known.length - 1)))];
    [qlo, qhi] = [at(trim), at(1 - trim)];
  }
  const raw = Math.max(qhi - qlo, minSpan) / OV_HIST_BINS;
  const mag = 10 ** Math.floor(Math.log10(raw));
  const width = OV_BIN_STEPS.map((m) => m * mag).find((w) => w >= raw) || 10 * mag;
  return { width, lo, hi, maxAbs: Math.max(Math.abs(lo), Math.abs(hi)) };
}

// Counts over the known values v + shift: per bin k (floor((v + shift) / binWidth)), outside the zone
// [zone[0], zone[1]], past the divergence limit (> divergence); and their mean.
function ovCount(values, { shift = 0, binWidth, zone, divergence }) {
  const counts = new Map();
  let known = 0, outside = 0, diverging = 0, sum = 0;
  const [zlo, zhi] = zone;
  for (const p of values) {
    if (!Number.isFinite(p)) continue;
    const v = p + shift;
    known++; sum += v;
    if (v < zlo || v > zhi) outside++;
    if (v > divergence) diverging++;
    const k = Math.floor(v / binWidth);
    counts.set(k, (counts.get(k) || 0) + 1);
  }
  return { counts, known, outside, diverging, mean: known ? sum / known : NaN };
}

// The histogram of counts (ovCount) as % of the known values against the comfort zone (shaded) and the
// divergence limit (a red line, its side shaded when it is on the plot). opts: binWidth, zone, divergence,
// span ([lo, hi] the values may reach: the x range is fixed by it, not by the counts), xlabel, zoneLabel.
// Answers whether the limit is on the plot.
function ovDrawHistogram(svg, state, opts) {
  const { binWidth: w, zone, divergence } = opts;
  const bars = [...state.counts.entries()].sort((a, b) => a[0] - b[0]).map(([k, c]) => ({
    lo: Number((k * w).toPrecision(12)), hi: Number(((k + 1) * w).toPrecision(12)), value: 100 * c / state.known,
    cls: (k + 1) * w <= zone[0] || k * w >= zone[1] ? "st-bar-out" : "" }));
  const lo = Math.min(opts.span[0], zone[0]) - w, hi = Math.max(opts.span[1], zone[1]) + w;
  const divOn = divergence <= hi + 0.5 * (hi - lo);  // far off the plot: said beside its share instead
  const xhi = divOn ? Math.max(hi, divergence + w) : hi;
  drawHistogram(svg, bars, {
    xrange: [lo, xhi], xlabel: opts.xlabel, ylabel: "% of pixels",
    bands: [{ from: zone[0], to: zone[1], cls: "st-zone", label: opts.zoneLabel },
      ...(divOn ? [{ from: divergence, to: xhi, cls: "shade", label: "diverging" }] : [])],
    vlines: [{ x: 0, label: "screen" }, { x: divergence, label: "", cls: "st-div-line" }],
  });
  svg.dataset.mean = String(state.mean);
  svg.dataset.binWidth = String(w);
  svg.dataset.known = String(state.known);
  return divOn;
}

// A share beside the histogram: "12.3 % (45 of 366)" and more, data-value the share unrounded.
function ovShare(node, count, known, more = "") {
  const share = known ? count / known : 0;
  node.textContent = `${(100 * share).toFixed(1)} % (${count} of ${known})${more}`;
  node.dataset.value = String(share);
  node.dataset.count = String(count);
}
