"use strict";

// ---------------------------------------------------------------- page 4: the rig from above (drawing only)
// The plan of POST /api/rigs/plan (rigs.js) drawn in the world's x-z plane (the ground of a shot whose up is y),
// in metres at one scale on both axes, over a metres grid with labelled axes: the real cameras (filled), the
// virtual cameras (dashed), each camera's horizontal field of view (the rays through its image's left and right
// edges, to a common forward distance), the elements (the subject, ...), the convergence plane and a Tri-Rig's
// constraint depths and the near and far of its depth range. The world axis the shot looks along (x or z,
// whichever its camera's axis leans to) runs to the right, the other up. A label is placed where its box crosses
// no drawn line, marker or other label and stays inside the plot (rigPlaceLabel); one that finds no such spot is
// written in a legend under the plot.
const RIG_TOP = { width: 560, height: 380, left: 52, right: 12, top: 10, bottom: 40 };
const RIG_CLOSE = { width: 560, height: 200, left: 52, right: 12, top: 10, bottom: 40 };
const RIG_AXES = ["x", "y", "z"];
const RIG_PAD = 0.08;  // room around the drawn points, a share of the larger extent (labels go there)
const RIG_LEGEND_ROW = 15;  // px per legend row under the plot

const rigDot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
const rigSub = (a, b) => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
const rigAdd = (a, b, s = 1) => [a[0] + s * b[0], a[1] + s * b[1], a[2] + s * b[2]];
const rigNorm = (a) => { const n = Math.hypot(...a) || 1; return a.map((v) => v / n); };
const rigCross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];

// The shot camera's forward (its axis flattened on the ground) and right, depth along forward, and the 2-D point
// of the view: [world h, world v] in metres, h the axis forward leans to (z or x), v the other.
function rigBasis(shot, plan) {
  const ref = plan.rig === "quadri" ? plan.virtual.center : plan.cameras[0].camera;
  const up = rigNorm(shot.camera.up || [0, 1, 0]);
  const axis = ref.R[2];
  const forward = rigNorm(rigSub(axis, up.map((v) => v * rigDot(axis, up))));
  const right = rigCross(forward, up);
  const origin = ref.center;
  const h = Math.abs(forward[2]) >= Math.abs(forward[0]) ? 2 : 0;
  const v = 2 - h;
  return { origin, forward, right, h, v, depth: (p) => rigDot(rigSub(p, origin), forward),
    across: (p) => rigDot(rigSub(p, origin), right), project: (p) => [p[h], p[v]] };
}

// A camera's horizontal field of view: the world directions through its image's left and right edges.
function rigEdges(cam) {
  const [fx, cx] = [cam.K[0][0], cam.K[0][2]];
  return [0, cam.width].map((x) => rigAdd(cam.R[2], cam.R[0], (x - cx) / fx));
}

function rigShapes(shot, plan, basis, reach) {
  const shapes = [];  // {kind, role, pts: [[h, v], ...] metres, name, label}
  const camera = (name, cam, role) => {
    const c = cam.center;
    const start = basis.depth(c);
    for (const dir of rigEdges(cam)) {  // each edge ray runs to the same forward distance, `reach` from the origin
      const along = rigDot(dir, basis.forward);
      if (along > 1e-9 && reach > start) {
        shapes.push({ kind: "line", role,
          pts: [basis.project(c), basis.project(rigAdd(c, dir, (reach - start) / along))] });
      }
    }
    shapes.push({ kind: "camera", role, pts: [basis.project(c)], name });
  };
  if (plan.rig === "quadri") {
    camera("virtual left", plan.virtual.left, "virtual");
    camera("virtual right", plan.virtual.right, "virtual");
    for (const row of plan.cameras) {
      camera(row.name, row.camera, row.element === plan.elements[0].name ? "subject" : "other");
    }
    for (const e of plan.elements) {
      shapes.push({ kind: "element", pts: [basis.project(e.point)], name: e.name, label: e.name });
    }
    const c = plan.virtual.center;
    const h = shot.convergence;
    const half = h * (c.width / 2) / c.K[0][0];
    const mid = rigAdd(c.center, basis.forward, h);
    shapes.push({ kind: "plane",
      pts: [basis.project(rigAdd(mid, basis.right, -half)), basis.project(rigAdd(mid, basis.right, half))],
      label: `convergence H_v = ${fmt(h)} m` });
  } else {
    camera("reference right", plan.reference_right, "virtual");
    plan.cameras.forEach((row, i) => camera(row.name, row.camera, ["director", "subject", "other"][i] || "other"));
    const d = plan.cameras[0].camera.center;
    const mid = rigAdd(rigAdd(d, rigSub(plan.reference_right.center, d), 0.5), basis.forward,
      plan.reference.convergence);
    const half = plan.reference.window / 2;
    shapes.push({ kind: "plane",
      pts: [basis.project(rigAdd(mid, basis.right, -half)), basis.project(rigAdd(mid, basis.right, half))],
      label: `convergence H = ${fmt(plan.reference.convergence)} m, window W = ${fmt(plan.reference.window)} m` });
    // the depth range psi maps (the shot's near and far, when given and finite), dotted
    for (const [name, z] of [["near", shot.near], ["far", shot.far]]) {
      if (!(Number.isFinite(z) && z > 0)) continue;
      const at = rigAdd(d, basis.forward, z);
      shapes.push({ kind: "range",
        pts: [basis.project(rigAdd(at, basis.right, -reach * 0.08)),
              basis.project(rigAdd(at, basis.right, reach * 0.08))],
        label: `${name} z = ${fmt(z)} m` });
    }
    for (const text of shot.constraints) {
      const z = Number((/z=([^,]+)/.exec(text) || [])[1]);
      const p = (/perceived=([^,]+)/.exec(text) || [])[1];
      if (Number.isFinite(z) && z > 0) {
        const at = rigAdd(d, basis.forward, z);
        shapes.push({ kind: "depth",
          pts: [basis.project(rigAdd(at, basis.right, -reach * 0.04)),
                basis.project(rigAdd(at, basis.right, reach * 0.04))],
          label: `z = ${fmt(z)} m → z′ = ${p} m` });
      }
    }
  }
  return shapes;
}

// One scale on both axes, the points centred in the plot with RIG_PAD around them; h to the right, v up.
// Answers the mapping (at: metres -> SVG px) and the metres at the plot's edges.
function rigFit(points, box, minExtent) {
  const hs = points.map((p) => p[0]), vs = points.map((p) => p[1]);
  let [h0, h1, v0, v1] = [Math.min(...hs), Math.max(...hs), Math.min(...vs), Math.max(...vs)];
  const pad = RIG_PAD * Math.max(h1 - h0, v1 - v0, minExtent);
  const grow = (lo, hi) => {
    const more = Math.max(0, minExtent - (hi - lo)) / 2 + pad;
    return [lo - more, hi + more];
  };
  [h0, h1] = grow(h0, h1);
  [v0, v1] = grow(v0, v1);
  const plot = { x0: box.left, x1: box.width - box.right, y0: box.top, y1: box.height - box.bottom };
  const scale = Math.min((plot.x1 - plot.x0) / (h1 - h0), (plot.y1 - plot.y0) / (v1 - v0));
  const xc = (plot.x0 + plot.x1) / 2, yc = (plot.y0 + plot.y1) / 2, hc = (h0 + h1) / 2, vc = (v0 + v1) / 2;
  const at = ([h, v]) => [xc + (h - hc) * scale, yc - (v - vc) * scale];
  const metres = { h: [hc + (plot.x0 - xc) / scale, hc + (plot.x1 - xc) / scale],
    v: [vc - (plot.y1 - yc) / scale, vc - (plot.y0 - yc) / scale] };
  return { scale, at, plot, metres };
}

// The metres grid (one step on both axes: square cells), its tick labels in the margins, the frame and the axes' names.
function rigGrid(svg, box, fit, basis) {
  const { plot, metres } = fit;
  // about 7 cells across, and at least 2 lines up (a close-up's short side)
  const stepOf = (lo, hi, n) => { const t = niceTicks(lo, hi, n).ticks; return t.length > 1 ? t[1] - t[0] : hi - lo; };
  const step = Math.min(stepOf(...metres.h, 7), stepOf(...metres.v, 3));
  const g = el("g", { class: "rig-grid" });
  const values = (lo, hi) => {
    const out = [];
    for (let k = Math.ceil(lo / step); k * step <= hi; k++) out.push(Number((k * step).toPrecision(12)));
    return out;
  };
  for (const m of values(...metres.h)) {
    const [x] = fit.at([m, 0]);
    g.append(el("line", { x1: x, x2: x, y1: plot.y0, y2: plot.y1, class: "grid", "data-axis": "h",
      "data-m": String(m) }));
    g.append(el("text", { x, y: plot.y1 + 13, "text-anchor": "middle" }, fmt(m, 4)));
  }
  for (const m of values(...metres.v)) {
    const [, y] = fit.at([0, m]);
    g.append(el("line", { x1: plot.x0, x2: plot.x1, y1: y, y2: y, class: "grid", "data-axis": "v",
      "data-m": String(m) }));
    g.append(el("text", { x: plot.x0 - 5, y: y + 4, "text-anchor": "end" }, fmt(m, 4)));
  }
  g.append(el("rect", { x: plot.x0, y: plot.y0, width: plot.x1 - plot.x0, height: plot.y1 - plot.y0, class: "frame" }));
  const hName = RIG_AXES[basis.h], vName = RIG_AXES[basis.v];
  g.append(el("text", { x: (plot.x0 + plot.x1) / 2, y: plot.y1 + 30, "text-anchor": "middle", class: "label" },
    `${hName} (m), grid every ${fmt(step)} m`));
  const ym = (plot.y0 + plot.y1) / 2;
  g.append(el("text", { x: 12, y: ym, "text-anchor": "middle", class: "label", transform: `rotate(-90 12 ${ym})` },
    `${vName} (m)`));
  svg.append(g);
  Object.assign(svg.dataset, { hAxis: hName, vAxis: vName, gridM: String(step) });
}

// A text's box: getBBox when the SVG is laid out, else an estimate from its length (11 px text).
function rigBox(text) {
  const b = text.getBBox();
  if (b.width > 0) return { x: b.x, y: b.y, width: b.width, height: b.height };
  const width = 6.2 * text.textContent.length, x = Number(text.getAttribute("x")), y = Number(text.getAttribute("y"));
  const anchor = text.getAttribute("text-anchor") || "start";
  return { x: anchor === "end" ? x - width : anchor === "middle" ? x - width / 2 : x, y: y - 10, width, height: 13 };
}

// Whether the segment a-b meets the box b (grown by pad), by clipping (Liang-Barsky).
function rigHits([x1, y1], [x2, y2], box, pad = 1) {
  const bx0 = box.x - pad, bx1 = box.x + box.width + pad, by0 = box.y - pad, by1 = box.y + box.height + pad;
  let t0 = 0, t1 = 1;
  const dx = x2 - x1, dy = y2 - y1;
  for (const [p, q] of [[-dx, x1 - bx0], [dx, bx1 - x1], [-dy, y1 - by0], [dy, by1 - y1]]) {
    if (p === 0) { if (q < 0) return false; continue; }
    const t = q / p;
    if (p < 0) { if (t > t1) return false; if (t > t0) t0 = t; } else { if (t < t0) return false; if (t < t1) t1 = t; }
  }
  return true;
}

const rigOverlap = (a, b, pad = 1) => a.x < b.x + b.width + pad && b.x < a.x + a.width + pad
  && a.y < b.y + b.height + pad && b.y < a.y + a.height + pad;

// Places `text` near one of `anchors` (SVG px; a line's two ends): the first spot, on rings of growing radius round
// each anchor in 16 directions, whose box lies inside the plot and meets no segment and no box taken; answers its
// box, or null (the text is removed).
function rigPlaceLabel(g, text, anchors, plot, segments, taken) {
  g.append(text);
  for (const r of [7, 12, 20, 30, 44, 62, 86, 120]) {
    for (const anchor of anchors) for (let k = 0; k < 16; k++) {
      const a = Math.PI / 2 + (k * Math.PI) / 8;  // below the anchor first, then round
      const cx = anchor[0] + r * Math.cos(a), cy = anchor[1] + r * Math.sin(a);
      const side = Math.cos(a) > 0.3 ? "start" : Math.cos(a) < -0.3 ? "end" : "middle";
      text.setAttribute("x", cx); text.setAttribute("y", cy + 4); text.setAttribute("text-anchor", side);
      const box = rigBox(text);
      if (box.x < plot.x0 + 2 || box.x + box.width > plot.x1 - 2
          || box.y < plot.y0 + 2 || box.y + box.height > plot.y1 - 2) continue;
      if (segments.some(([p, q]) => rigHits(p, q, box)) || taken.some((t) => rigOverlap(t, box))) continue;
      return box;
    }
  }
  text.remove();
  return null;
}

// names: the cameras' names too (the close-up; in the top view the cameras stand too close to name).
function rigDrawShapes(svg, shapes, fit, box, basis, { names }) {
  svg.replaceChildren();
  svg.setAttribute("viewBox", `0 0 ${box.width} ${box.height}`);
  rigGrid(svg, box, fit, basis);
  const g = el("g", { class: "rig-view" });
  const segments = [], taken = [], labels = [];
  let count = 0;
  for (const s of shapes) {
    const pts = s.pts.map(fit.at);
    if (s.kind === "line" || s.kind === "plane" || s.kind === "depth" || s.kind === "range") {
      g.append(el("line", { x1: pts[0][0], y1: pts[0][1], x2: pts[1][0], y2: pts[1][1],
        class: s.kind === "line" ? `rig-ray ${s.role}` : `rig-${s.kind}` }));
      segments.push(pts);
      if (s.label) labels.push({ text: s.label, at: [pts[1], pts[0]], cls: `rig-${s.kind}-label` });
    } else if (s.kind === "element") {
      g.append(el("rect", { x: pts[0][0] - 4, y: pts[0][1] - 4, width: 8, height: 8, class: "rig-element",
        "data-element": s.name }));
      taken.push({ x: pts[0][0] - 4, y: pts[0][1] - 4, width: 8, height: 8 });
      labels.push({ text: s.label, at: [pts[0]], cls: "label" });
    } else if (s.kind === "camera") {
      const attrs = { cx: pts[0][0], cy: pts[0][1], r: 4, class: `rig-camera ${s.role}` };
      if (s.role !== "virtual") { attrs["data-camera"] = s.name; count++; } else attrs["data-virtual"] = s.name;
      g.append(el("circle", attrs));
      taken.push({ x: pts[0][0] - 4, y: pts[0][1] - 4, width: 8, height: 8 });
    }
  }
  svg.append(g);
  // the cameras' names: one label per place (a Tri-Rig's subject and reference right share theirs)
  const spots = new Map();
  for (const s of shapes.filter((t) => names && t.kind === "camera")) {
    const [x, y] = fit.at(s.pts[0]);
    const key = `${Math.round(x)},${Math.round(y)}`;
    if (!spots.has(key)) spots.set(key, { at: [[x, y]], names: [] });
    spots.get(key).names.push(s.name);
  }
  labels.push(...[...spots.values()].map((spot) => ({ text: spot.names.join(" = "), at: spot.at, cls: "rig-name" })));
  const group = el("g", { class: "rig-labels" });
  svg.append(group);
  const legend = [];
  for (const label of labels) {
    const text = el("text", { class: `${label.cls} halo`, "data-label": label.text }, label.text);
    const placed = rigPlaceLabel(group, text, label.at, fit.plot, segments, taken);
    if (placed) taken.push(placed); else legend.push(label.text);
  }
  // what found no free spot: a legend under the plot
  legend.forEach((text, i) => {
    group.append(el("text", { x: box.left, y: box.height + RIG_LEGEND_ROW * (i + 0.8), class: "label",
      "data-label": text, "data-legend": "true" }, `not placed on the plot: ${text}`));
  });
  svg.setAttribute("viewBox", `0 0 ${box.width} ${box.height + RIG_LEGEND_ROW * legend.length}`);
  svg.dataset.cameras = String(count);
  svg.dataset.legend = String(legend.length);
}

function rigDrawTop(shot, plan) {
  const basis = rigBasis(shot, plan);
  const centres = [...plan.cameras.map((r) => r.camera.center),
    ...(plan.rig === "tri" ? [plan.reference_right.center] : [])];
  const far = plan.rig === "quadri"
    ? Math.max(...plan.elements.map((e) => basis.depth(e.point)))
    : Math.max(plan.reference.convergence, ...[shot.near, shot.far].filter(Number.isFinite),
      ...shot.constraints.map((t) => Number((/z=([^,]+)/.exec(t) || [])[1])).filter(Number.isFinite));
  const reach = 1.15 * Math.max(far, 1e-3);
  const shapes = rigShapes(shot, plan, basis, reach);
  const top = rigEl("rig-top");
  rigDrawShapes(top, shapes, rigFit(shapes.flatMap((s) => s.pts), RIG_TOP, 1), RIG_TOP, basis, { names: false });
  // the close-up: the camera line only, its rays short
  // (a Quadri-Rig's virtual eyes stand the setback ahead: left out of the close-up)
  const spread = Math.max(...centres.map(basis.across)) - Math.min(...centres.map(basis.across));
  const shortReach = Math.max(...centres.map(basis.depth)) + Math.max(spread, 0.2) * 0.6;
  const closeShapes = rigShapes(shot, plan, basis, shortReach)
    .filter((s) => (s.kind === "camera" || s.kind === "line") && !(plan.rig === "quadri" && s.role === "virtual"));
  rigDrawShapes(rigEl("rig-close"), closeShapes, rigFit(closeShapes.flatMap((s) => s.pts), RIG_CLOSE, 0.2), RIG_CLOSE,
    basis, { names: true });
}
