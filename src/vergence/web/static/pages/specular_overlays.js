"use strict";

// ---------------------------------------------------------------- page 5's overlays (specular.js's results)
// docs/workbench.md, "Overlays". For the shown result (the specular job or its latest re-optimisation): its
// disparity_after.npy ((N, H, W) float32: each layer's horizontal disparity, optimised left eye against the
// right eye, in arcmin of vergence on the display as the image is shown, positive behind the screen, NaN where
// the layer has no match; spec.overlay) and GET /api/specular/{id}/overlay (the comfort zone, the divergence
// limit and the colour scale, arcmin). Drawn: the chosen layer's heat map over its picture (layer_<n>.png of the
// first run: the physical left eye's layer), the colour bar, and the histogram of every layer's matched pixels
// pooled, with the plain shares inside the zone and past the limit, and the chosen layer's share inside.
// The colours, the counts and the histogram are overlays.js's.
const specOv = { id: null, geo: null, bins: null, token: 0, picture: null };
const SPEC_OV_TRIM = 0.005;  // the bin width from the 0.5-99.5 % range: a few mismatched far pixels keep it fine

function specOvLayer() { return Number(document.getElementById("spec-ov-layer").value); }

// The chosen layer's plane of the disparity array.
function specOvPlane(layer) {
  const o = spec.overlay;
  return o.data.subarray((layer - 1) * o.width * o.height, layer * o.width * o.height);
}

async function specLoadOverlays(id) {
  const token = ++specOv.token;
  const box = document.getElementById("spec-ov");
  box.dataset.state = "loading";
  const scale = document.getElementById("spec-heat-scale").value;
  const [geo] = await Promise.all([api(`/api/specular/${id}/overlay?scale_arcmin=${encodeURIComponent(scale)}`),
    specLoadOverlay(id)]);
  if (token !== specOv.token) return;  // a later result or choice won
  Object.assign(specOv, { id, geo, bins: ovBins(spec.overlay.data, 1, SPEC_OV_TRIM) });
  const select = document.getElementById("spec-ov-layer");
  const kept = select.value;
  select.replaceChildren(...geo.layers.map((l) => {
    const plane = specOvPlane(l.layer);
    const matched = plane.reduce((n, v) => n + Number.isFinite(v), 0);
    const option = new Option(`${l.layer} · ${l.name} (${matched} px matched)`, String(l.layer));
    option.dataset.matched = String(matched);
    return option;
  }));
  const options = [...select.options];
  const first = options.find((o) => o.value !== "1" && Number(o.dataset.matched) > 0) || options[0];
  select.value = options.some((o) => o.value === kept) ? kept : first.value;
  await specOvPicture();
  if (token !== specOv.token) return;
  specDrawOverlays();
  box.dataset.job = id;
  box.dataset.state = "ready";
}

// The chosen layer's picture (the first run's layer_<n>.png) under the heat map.
async function specOvPicture() {
  const layer = specOvLayer();
  specOv.picture = await ovImage(jobFile(spec.base, `layer_${layer}.png`));
  const canvas = document.getElementById("spec-ov-picture");
  canvas.width = spec.overlay.width; canvas.height = spec.overlay.height;
  const ctx = canvas.getContext("2d");
  ctx.imageSmoothingEnabled = false;
  ctx.drawImage(specOv.picture, 0, 0, canvas.width, canvas.height);
}

function specDrawOverlays() {
  const { geo, bins } = specOv;
  if (!geo || !spec.overlay) return;
  const o = spec.overlay;
  const layer = specOvLayer();
  const plane = specOvPlane(layer);
  const heat = document.getElementById("spec-heat-canvas");
  ovDrawHeat(heat, plane, o.width, o.height, geo.scale.arcmin);
  heat.hidden = !document.getElementById("spec-heat").checked;
  heat.style.opacity = String(Number(document.getElementById("spec-heat-opacity").value) / 100);
  const [zlo, zhi] = geo.zone_arcmin;
  ovHeatBar(document.getElementById("spec-heat-bar"), {
    range: geo.scale.arcmin, marks: geo.zone_arcmin, units: ["arcmin"],
    ticks: geo.scale.ticks.map((t) => ({ value: t, label: `${fmt(t, 3)}′`, attrs: { "data-arcmin": String(t) } })),
    caption: `vergence on ${geo.display || "the display"} (fit ${geo.fit})`
      + ` · red: in front of the screen, blue: behind`,
  });
  const counting = { binWidth: bins.width, zone: geo.zone_arcmin, divergence: geo.divergence_arcmin };
  const all = ovCount(o.data, counting);
  const svg = document.getElementById("spec-hist");
  const divOn = ovDrawHistogram(svg, all, { ...counting, span: [bins.lo, bins.hi],
    xlabel: "horizontal disparity after the solve, arcmin of vergence (negative: in front of the screen)",
    zoneLabel: `comfort zone ${fmt(zlo, 3)}′ to ${fmt(zhi, 3)}′` });
  ovShare(document.getElementById("spec-share-inside"), all.known - all.outside, all.known);
  ovShare(document.getElementById("spec-share-div"), all.diverging, all.known,
    `; the limit at ${fmt(geo.divergence_arcmin, 4)}′${divOn ? "" : ", off the plot"}`);
  const one = ovCount(plane, counting);
  const mine = document.getElementById("spec-share-layer");
  ovShare(mine, one.known - one.outside, one.known);
  mine.dataset.layer = String(layer);
  document.getElementById("spec-share-layer-name").textContent = `layer ${layer}`;
  document.getElementById("spec-ov").dataset.layer = String(layer);
}

function specOverlaysError(exc) {
  document.getElementById("spec-ov").dataset.state = "error";
  showError(exc.message);
  document.body.dataset.state = "error";
}

function specInitOverlays() {
  document.getElementById("spec-ov-layer").addEventListener("change", () => {
    specOvPicture().then(specDrawOverlays).catch(specOverlaysError);
  });
  document.getElementById("spec-heat").addEventListener("change", specDrawOverlays);
  document.getElementById("spec-heat-opacity").addEventListener("input", () => {
    document.getElementById("spec-heat-canvas").style.opacity =
      String(Number(document.getElementById("spec-heat-opacity").value) / 100);
  });
  document.getElementById("spec-heat-scale").addEventListener("change", () => {
    if (spec.shown) specLoadOverlays(spec.shown).catch(specOverlaysError);
  });
}
