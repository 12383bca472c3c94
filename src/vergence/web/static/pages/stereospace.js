"use strict";

// ---------------------------------------------------------------- page 3: StereoSpace browser (S2)
// Prepares a collection (POST /api/jobs/stereospace: progress by SSE, cancel), reads its map (map.json), then
// browses: each move is POST /api/stereospace/{job}/move (S2 §4.1: pan, zoom, jumps at region borders), each
// view POST /api/stereospace/{job}/pair (the pair's images by URL). The page keeps only the state the server
// answered; moves asked while one is running are summed and sent as one.
// With WebGL2 (issue 30) the page draws each pair itself from the job's scene (stereospace_cams.js,
// stereospace_gl.js: the same cameras, MLS maps and ULR blend as the server's pair) and animates each move at the
// display's frame rate (within a region along the parameters, across a jump between the eyes' cameras); the server
// still decides every move (POST .../move). Without WebGL2, or for a layout it does not draw, the server's PNG.
const SS = {
  job: null, preparing: null, result: null, map: null, view: null, pair: null,
  busy: false, pending: { pan: 0, zoom: 0 }, vr: false, drag: null,
  gl: null, frames: [], timing: false,  // the browser renderer; per frame {t, ms} (timing: wait for the GPU)
};
const SS_ANIMATE_MS = 200;  // a move's animation
// Frames while the view moves are drawn at the working width / SS_MOTION_DIVISOR (the canvas scales them to the
// same size on screen), the still frame at the full working width as soon as the move ends; the page says which.
// On this project's 2-core machine without a GPU (SwiftShader, load 5-7) a full 320 px frame takes 70-130 ms,
// a motion frame at 80 px 9-18 ms (benchmarks/stereospace_browser.py, tests/web/test_browser_stereospace_gl.py).
const SS_MOTION_DIVISOR = 4;
const SS_WIDTHS = [160, 240, 320, 480, 640, 960, 1280];
const SS_DRAG_STEPS = 8;  // pan steps for a drag across the whole view or map
const SS_MAP = { width: 600, height: 480, pad: 16 };

async function initStereospace() {
  document.body.dataset.state = "loading";
  try {
    const [data, displays] = await Promise.all([api("/api/data"), api("/api/displays")]);
    const select = document.getElementById("ss-collection");
    for (const entry of data.collections) select.add(new Option(`${entry.name} (${entry.format})`, entry.id));
    document.getElementById("ss-none").hidden = data.collections.length > 0;
    document.getElementById("ss-prepare").disabled = data.collections.length === 0;
    const display = document.getElementById("ss-display");
    for (const d of displays.displays) if (d.resolution) display.add(new Option(d.name, d.name));
    if ([...display.options].some((o) => o.value === "desktop-24")) display.value = "desktop-24";
    document.getElementById("ss-prepare").addEventListener("click", ssPrepare);
    document.getElementById("ss-cancel").addEventListener("click", () => {
      if (SS.preparing) cancelJob(SS.preparing);
    });
    for (const button of document.querySelectorAll("#ss-controls button")) {
      button.addEventListener("click", () => ssMove(Number(button.dataset.pan || 0), Number(button.dataset.zoom || 0)));
    }
    document.getElementById("ss-format").addEventListener("change", () => ssShowPair());
    document.getElementById("ss-width").addEventListener("change", () => ssShowPair());
    document.getElementById("ss-overlay").addEventListener("change", ssPlaceMap);
    ssPlaceMap();
    document.addEventListener("keydown", ssKey);
    for (const id of ["ss-view", "ss-map"]) ssPointer(document.getElementById(id));
    document.body.dataset.state = "ready";
  } catch (exc) {
    showError(exc.message);
    document.body.dataset.state = "error";
  }
}

function ssRequest() {
  return {
    collection: document.getElementById("ss-collection").value,
    grid_step: Number(document.getElementById("ss-detail").value),
    display: document.getElementById("ss-display").value,
  };
}

async function ssPrepare() {
  showError(null);
  document.body.dataset.state = "loading";
  document.getElementById("ss-prepare").disabled = true;
  document.getElementById("ss-controls").disabled = true;
  const progress = document.getElementById("ss-progress");
  const message = document.getElementById("ss-message");
  let status;
  try {
    status = await runJob("stereospace", ssRequest(), {
      onStart: (id) => { SS.preparing = id; document.getElementById("ss-cancel").disabled = false; },
      onProgress: (s) => {
        progress.value = s.progress || 0;
        message.textContent = `${Math.round(100 * (s.progress || 0))} % ${s.message || ""}`;
      },
    });
  } catch (exc) {
    status = { state: "failed", error: exc.message };
  }
  SS.preparing = null;
  document.getElementById("ss-cancel").disabled = true;
  document.getElementById("ss-prepare").disabled = false;
  if (!jobDone(status, message)) return;
  progress.value = 1;
  const r = status.result;
  message.textContent = `${status.cached ? "done (cached)" : "done"}: ${r.cameras} cameras, ${r.points} points, `
    + `${r.segments} segments, ${r.regions} regions in ${fmt(r.seconds, 2)} s`;
  try {
    SS.map = await api(jobFile(status.id, "map.json"));
  } catch (exc) {
    showError(exc.message);
    document.body.dataset.state = "error";
    return;
  }
  SS.job = status.id;
  SS.result = r;
  SS.pending = { pan: 0, zoom: 0 };
  await ssStartGL(status.id);
  ssOptions(r);
  const browser = document.getElementById("ss-browser");
  browser.dataset.job = status.id;
  browser.hidden = false;
  document.getElementById("ss-controls").disabled = false;
  ssShowState(r.start, null);
  await ssShowPair();
}

// the browser renderer of a job's scene, or null (the page then shows the server's pairs, and says so)
async function ssStartGL(job) {
  const note = document.getElementById("ss-renderer");
  if (SS.gl) SS.gl.dispose();  // the previous collection's textures, frame buffers and programs
  SS.gl = null;
  let gl = null, why = "WebGL2 is not available in this browser";
  try {
    const forced = new URLSearchParams(location.search).get("renderer") === "server";
    if (forced) why = "?renderer=server asked";
    else if (typeof SSGL !== "undefined") gl = SSGL.create(document.getElementById("ss-canvas"));
    if (gl) await gl.load(await api(`/api/stereospace/${job}/scene`));
  } catch (exc) {
    why = `the browser renderer failed (${exc.message})`;
    gl = null;
  }
  if (job !== SS.job && SS.job !== null) return;
  SS.gl = gl;
  note.dataset.renderer = gl ? "webgl2" : "server";
  note.textContent = gl ? `Drawn in the browser (WebGL2 on ${gl.name}, MLS maps `
    + `${gl.maps() === "gpu" ? "in a shader pass" : "in JavaScript"}); moves animate. `
    + `Layouts ${SSGL.FORMATS.join(", ")}; `
    + "the others come from the server." : `${why}: each pair is drawn by the server.`;
}

function ssOptions(r) {
  const format = document.getElementById("ss-format");
  const keep = format.value || "anaglyph";
  format.replaceChildren(...r.formats.map((f) => new Option(f, f)));
  format.value = r.formats.includes(keep) ? keep : r.formats[0];
  const width = document.getElementById("ss-width");
  const widths = SS_WIDTHS.filter((w) => w >= r.min_width && w <= r.image_width);
  if (!widths.includes(r.default_width)) widths.push(r.default_width);
  widths.sort((a, b) => a - b);
  width.replaceChildren(...widths.map((w) => new Option(`${w} px`, String(w))));
  width.value = String(r.default_width);
}

function ssStateBody(view) { return { region: view.region, li: view.li, lj: view.lj }; }

// ---------------------------------------------------------------- moves
function ssMove(panSteps, zoomSteps) {
  if (!SS.job) return;
  const r = SS.result;
  // the arrow keys move the stereo camera left or right on screen: the server's pan_right is the sign of the pan
  // towards the view's world right (not the eyes' order, which flips inside some regions: issue 30)
  const sign = SS.view ? SS.view.pan_right : 1;
  const clamp = (v) => Math.max(-r.max_move, Math.min(r.max_move, v));
  SS.pending.pan = clamp(SS.pending.pan + sign * panSteps * r.pan_step);
  SS.pending.zoom = clamp(SS.pending.zoom + zoomSteps * r.zoom_step);
  if (!SS.busy) ssRunMoves();
}

async function ssRunMoves() {
  SS.busy = true;
  document.body.dataset.state = "loading";
  try {
    while (SS.pending.pan !== 0 || SS.pending.zoom !== 0) {
      const { pan, zoom } = SS.pending;
      SS.pending = { pan: 0, zoom: 0 };
      const job = SS.job;
      const answer = await api(`/api/stereospace/${job}/move`, { state: ssStateBody(SS.view), pan, zoom });
      if (job !== SS.job) return;
      if (ssDrawsHere()) await ssAnimate(SS.view, answer.state);
      ssShowState(answer.state, answer);
      if (SS.pending.pan === 0 && SS.pending.zoom === 0) await ssShowPair(true);
    }
    document.body.dataset.state = "ready";
  } catch (exc) {
    SS.pending = { pan: 0, zoom: 0 };
    showError(exc.message);
    document.body.dataset.state = "error";
  } finally {
    SS.busy = false;
  }
}

function ssKey(ev) {
  const section = document.getElementById("page-stereospace");
  if (!SS.job || !section || section.hidden) return;
  if (ev.target && ["INPUT", "SELECT", "TEXTAREA"].includes(ev.target.tagName)) return;
  if (ev.ctrlKey || ev.metaKey || ev.altKey) return;
  const moves = { ArrowLeft: [-1, 0], ArrowRight: [1, 0], "+": [0, 1], "=": [0, 1], "-": [0, -1], _: [0, -1] };
  const move = moves[ev.key];
  if (!move) return;
  ev.preventDefault();
  ssMove(...move);
}

function ssPointer(node) {
  node.addEventListener("pointerdown", (ev) => {
    if (!SS.job) return;
    SS.drag = { x: ev.clientX, width: node.getBoundingClientRect().width || 1 };
    node.setPointerCapture(ev.pointerId);
  });
  node.addEventListener("pointermove", (ev) => {
    if (!SS.drag) return;
    const step = SS.drag.width / SS_DRAG_STEPS;
    const steps = Math.trunc((ev.clientX - SS.drag.x) / step);
    if (steps !== 0) {
      SS.drag.x += steps * step;
      ssMove(steps, 0);
    }
  });
  const end = () => { SS.drag = null; };
  node.addEventListener("pointerup", end);
  node.addEventListener("pointercancel", end);
  node.addEventListener("wheel", (ev) => {
    if (!SS.job) return;
    ev.preventDefault();
    ssMove(0, ev.deltaY < 0 ? 1 : -1);
  }, { passive: false });
}

// ---------------------------------------------------------------- what the page shows
// the map over the view as a semi-transparent inset (S2 Fig. 10; the toggle, on by default), or beside it
function ssPlaceMap() {
  const over = document.getElementById("ss-overlay").checked, svg = document.getElementById("ss-map");
  const box = document.getElementById("ss-map-box");
  if (over) document.getElementById("ss-view").append(svg);
  else box.append(svg);
  box.hidden = over;
  document.getElementById("ss-browser").classList.toggle("ss-overlaid", over);
}

function ssSet(id, value, text) {
  const node = document.getElementById(id);
  node.textContent = text;
  node.dataset.value = JSON.stringify(value);
}

function ssShowState(view, answer) {
  SS.view = view;
  ssSet("ss-region", view.region, `(${view.region[0]}, ${view.region[1]})`);
  ssSet("ss-li", view.li, fmt(view.li, 4));
  ssSet("ss-lj", view.lj, fmt(view.lj, 4));
  ssSet("ss-interocular", view.interocular, `${fmt(view.interocular, 4)} (collection units)`);
  const [a, b] = view.segments;
  document.getElementById("ss-segments").textContent = `First eye on ${a[0]} – ${a[1]}, second eye on `
    + `${b[0]} – ${b[1]}${view.swapped ? " (the second eye is the left one)" : ""}.`;
  const event = document.getElementById("ss-event");
  event.dataset.event = answer ? answer.event : "start";
  event.className = `ss-event ${answer ? answer.event : ""}`;
  if (!answer) event.textContent = "Start: the three consecutive cameras with the smallest disparity range.";
  else if (answer.event === "jumped") {
    const s = answer.steps.find((x) => x.event === "jumped");
    event.textContent = `Jumped (${s.action}): from region (${s.from.region.join(", ")}) to region `
      + `(${s.to.region.join(", ")}) at its border.`;
  } else if (answer.event === "stopped") {
    const s = answer.steps.find((x) => x.event === "stopped");
    event.textContent = `Stopped (${s.action}) at the border of region (${s.to.region.join(", ")}): no region in the `
      + "40° cone.";
  } else event.textContent = `Moved within region (${view.region.join(", ")}).`;
  ssDrawMap(view);
}

// ---------------------------------------------------------------- the browser renderer
function ssDrawsHere() { return SS.gl !== null && SSGL.FORMATS.includes(document.getElementById("ss-format").value); }

// one frame: the pair of two eye cameras on the canvas; its time in SS.frames
function ssDrawCameras(first, second, moving = false) {
  const t0 = performance.now(), full = Number(document.getElementById("ss-width").value);
  const width = moving ? Math.max(SS.result.min_width, Math.round(full / SS_MOTION_DIVISOR)) : full;
  const pair = SS.gl.drawCameras(first, second, width, document.getElementById("ss-format").value);
  if (SS.timing) SS.gl.finish();
  SS.frames.push({ t: t0, ms: performance.now() - t0, width });
  const kind = document.getElementById("ss-frame");
  if (kind.dataset.width !== String(width)) {
    kind.dataset.width = String(width);
    kind.dataset.frame = moving ? "motion" : "still";
    kind.textContent = moving ? `Moving: drawn at ${width} px per view (${full} px when the view stops).`
      : `Still: drawn at the full ${width} px per view.`;
  }
  if (SS.frames.length > 1000) SS.frames.shift();
  ssFollowOnMap(pair.swapped ? second : first, pair.swapped ? first : second);
  return pair;
}

// the map's eyes, baseline and stereo camera at the frame's cameras (S2 Fig. 10: the map follows the view)
function ssFollowOnMap(left, right) {
  const m = SS.gl.scene().map, to = SS.mapXY;
  if (!to || !m) return;
  const xy = (c) => {
    const d = [0, 1, 2].map((k) => c[k] - m.origin[k]);
    return m.frame.map((r) => r[0] * d[0] + r[1] * d[1] + r[2] * d[2]);
  };
  const [l, r] = [xy(left.center), xy(right.center)], s = [(l[0] + r[0]) / 2, (l[1] + r[1]) / 2];
  const svg = document.getElementById("ss-map");
  const set = (sel, attrs) => {
    const node = svg.querySelector(sel);
    if (node) for (const [k, v] of Object.entries(attrs)) node.setAttribute(k, v);
  };
  set(".ss-baseline", { x1: to.X(l[0]), y1: to.Y(l[1]), x2: to.X(r[0]), y2: to.Y(r[1]) });
  set('[data-testid="ss-map-left-eye"]', { cx: to.X(l[0]), cy: to.Y(l[1]) });
  set('[data-testid="ss-map-right-eye"]', { cx: to.X(r[0]), cy: to.Y(r[1]) });
  set('[data-testid="ss-map-stereo"]', { x: Number(to.X(s[0])) - 5, y: Number(to.Y(s[1])) - 5 });
}

function ssDrawState(state, moving = false) {
  return ssDrawCameras(...SSCams.eyeCameras(SS.gl.scene(), state), moving);
}

// from one state to the next at the display's frame rate: along the parameters inside a region, between the eyes'
// cameras across a jump; a state on the way that cannot be drawn (no rectification) ends the animation
function ssAnimate(from, to) {
  const scene = SS.gl.scene();
  const same = from.region[0] === to.region[0] && from.region[1] === to.region[1];
  const [fa, fb] = SSCams.eyeCameras(scene, from), [ta, tb] = SSCams.eyeCameras(scene, to);
  return new Promise((resolve) => {
    let t0 = null;
    const frame = (now) => {
      t0 = t0 === null ? now : t0;
      const t = Math.min(1, (now - t0) / SS_ANIMATE_MS);
      try {
        if (same) {
          const li = from.li + t * (to.li - from.li), lj = from.lj + t * (to.lj - from.lj);
          ssDrawState({ region: to.region, li, lj }, true);
        } else ssDrawCameras(SSCams.interpolate(fa, ta, t), SSCams.interpolate(fb, tb, t), true);
      } catch (exc) {
        resolve();
        return;
      }
      if (t < 1) requestAnimationFrame(frame);
      else resolve();
    };
    requestAnimationFrame(frame);
  });
}

// Enter VR's pair: the eyes the page drew (PNG data URLs), else the server's last pair
function ssVRPair() {
  if (ssDrawsHere()) return { left: SS.gl.eyeURL(0), right: SS.gl.eyeURL(1) };
  return { left: SS.pair.images.left, right: SS.pair.images.right };
}

function ssShowDrawn(inMove) {
  const canvas = document.getElementById("ss-canvas"), img = document.getElementById("ss-pair");
  let pair;
  try {
    pair = ssDrawState(SS.view);
  } catch (exc) {
    document.getElementById("ss-view").classList.add("stale");
    if (inMove) throw exc;
    showError(`this pair cannot be shown: ${exc.message}`);
    document.body.dataset.state = "error";
    return;
  }
  canvas.style.display = "block";
  img.style.display = "none";  // (style.css shows .ss-view img as a block: the hidden attribute would not hide it)
  document.getElementById("ss-view").classList.remove("stale");
  const q = SS.view.quality, last = SS.frames[SS.frames.length - 1];
  ssSet("ss-range", q ? q.range_arcmin : null, q && q.range_arcmin !== null
    ? `${fmt(q.range_arcmin, 3)}′ (zone ${fmt(q.zone_arcmin[1] - q.zone_arcmin[0], 3)}′`
      + `${q.fits_with_shift ? ", fits with a shift" : ""})`
    : "— (mono)");
  document.getElementById("ss-caption").textContent = `The stereo view: ${document.getElementById("ss-format").value}, `
    + `${pair.left.width} × ${pair.left.height} per view, drawn in the browser in ${fmt(last.ms, 3)} ms.`;
  if (!SS.vr) {
    SS.vr = true;
    offerVR(document.getElementById("ss-vr"), ssVRPair);
  }
  showError(null);
  if (!inMove) document.body.dataset.state = "ready";
}

async function ssShowPair(inMove = false) {
  if (!SS.job || !SS.view) return;
  if (ssDrawsHere()) return ssShowDrawn(inMove);
  document.getElementById("ss-canvas").style.display = "none";
  document.getElementById("ss-pair").style.display = "";
  const kind = document.getElementById("ss-frame");  // the browser's frame note is not about the server's pair
  [kind.textContent, kind.dataset.width, kind.dataset.frame] = ["", "", "server"];
  const job = SS.job;
  const body = {
    state: ssStateBody(SS.view), format: document.getElementById("ss-format").value,
    width: Number(document.getElementById("ss-width").value),
  };
  if (!inMove) document.body.dataset.state = "loading";
  let answer;
  try {
    answer = await api(`/api/stereospace/${job}/pair`, body);
    const img = document.getElementById("ss-pair");
    img.src = answer.images.packed;
    await img.decode();
  } catch (exc) {
    document.getElementById("ss-view").classList.add("stale");  // the image shown is not this state's
    if (inMove) throw exc;
    showError(exc.message);
    document.body.dataset.state = "error";
    return;
  }
  if (job !== SS.job) return;
  SS.pair = answer;
  document.getElementById("ss-view").classList.remove("stale");
  const q = answer.quality;
  ssSet("ss-range", q ? q.range_arcmin : null, q && q.range_arcmin !== null
    ? `${fmt(q.range_arcmin, 3)}′ (zone ${fmt(q.zone_arcmin[1] - q.zone_arcmin[0], 3)}′`
      + `${q.fits_with_shift ? ", fits with a shift" : ""})`
    : "— (mono)");
  document.getElementById("ss-caption").textContent = `The stereo view: ${answer.format}, ${answer.width} × `
    + `${answer.height} per view, ${answer.cached ? "cached" : `${fmt(1000 * answer.seconds.pair, 3)} ms`}.`;
  if (!SS.vr) {
    SS.vr = true;
    offerVR(document.getElementById("ss-vr"), ssVRPair);
  }
  showError(null);  // a pair that could not be shown before (its error) is gone
  if (!inMove) document.body.dataset.state = "ready";
}

function ssDrawMap(view) {
  const svg = document.getElementById("ss-map");
  const m = SS.map;
  svg.replaceChildren();
  const [x0, y0, x1, y1] = m.bounds;
  const span = Math.max(x1 - x0, y1 - y0, 1e-9);
  const k = Math.min((SS_MAP.width - 2 * SS_MAP.pad) / Math.max(x1 - x0, span * 1e-3),
    (SS_MAP.height - 2 * SS_MAP.pad) / Math.max(y1 - y0, span * 1e-3));
  const ox = (SS_MAP.width - k * (x1 - x0)) / 2, oy = (SS_MAP.height - k * (y1 - y0)) / 2;
  const X = (x) => (ox + k * (x - x0)).toFixed(2);
  const Y = (y) => (oy + k * (y1 - y)).toFixed(2);  // "along" points up on the map
  SS.mapXY = { X, Y };
  svg.append(el("rect", { x: 0, y: 0, width: SS_MAP.width, height: SS_MAP.height, class: "ss-map-bg" }));
  let d = "";
  for (const [x, y] of m.points) d += `M${X(x)},${Y(y)}h0`;
  if (d) svg.append(el("path", { d, class: "ss-points" }));
  const cams = m.cameras;
  d = "";
  for (const [a, b] of m.segments) d += `M${X(cams[a].x)},${Y(cams[a].y)}L${X(cams[b].x)},${Y(cams[b].y)}`;
  svg.append(el("path", { d, class: "ss-graph" }));
  for (const p of m.paths) {
    svg.append(el("polyline", { points: p.map((c) => `${X(cams[c].x)},${Y(cams[c].y)}`).join(" "), class: "ss-path" }));
  }
  svg.append(el("polygon", { points: view.region_outline.map(([x, y]) => `${X(x)},${Y(y)}`).join(" "),
    class: "ss-region", "data-testid": "ss-map-region" }));
  const tick = 0.04 * Math.min(SS_MAP.width, SS_MAP.height);
  for (const c of cams) {
    svg.append(el("line", { x1: X(c.x), y1: Y(c.y), x2: (Number(X(c.x)) + tick * c.dx).toFixed(2),
      y2: (Number(Y(c.y)) - tick * c.dy).toFixed(2), class: "ss-tick" }));
    const dot = el("circle", { cx: X(c.x), cy: Y(c.y), r: 3.5, class: "ss-camera" });
    dot.append(el("title", {}, c.name));
    svg.append(dot);
  }
  const [l, r, s] = [view.eyes.left, view.eyes.right, view.stereo_camera];
  svg.append(el("line", { x1: X(l[0]), y1: Y(l[1]), x2: X(r[0]), y2: Y(r[1]), class: "ss-baseline" }));
  svg.append(el("rect", { x: Number(X(s[0])) - 5, y: Number(Y(s[1])) - 5, width: 10, height: 10, class: "ss-stereo",
    "data-testid": "ss-map-stereo", "data-x": s[0], "data-y": s[1] }));
  for (const [name, p] of [["left", l], ["right", r]]) {
    svg.append(el("circle", { cx: X(p[0]), cy: Y(p[1]), r: 5, class: `ss-eye ${name}`,
      "data-testid": `ss-map-${name}-eye`, "data-x": p[0], "data-y": p[1] }));
  }
  svg.append(el("text", { x: 8, y: SS_MAP.height - 8, class: "label" },
    `${SS.result.name}: ${cams.length} cameras, ${SS.result.regions} regions`));
}

registerPage("stereospace", initStereospace);
