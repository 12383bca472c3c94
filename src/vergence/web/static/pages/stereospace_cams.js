"use strict";

// ---------------------------------------------------------------- StereoSpace in the browser: cameras and MLS maps
// What vergence.stereospace.stereo_pair does before its per-pixel pass, for one state, in plain JavaScript (float64):
// the eyes' cameras interpolated on their segments (vergence.camera.interpolate: centres and intrinsics linear,
// rotations by slerp), ordered (eye_order against the collection's up), rectified together (Fusiello et al. 2000,
// vergence.depth.rectify_cameras: r1 along the baseline, r2 = k x r1, A = (K_l + K_r) / 2, the extents of the image
// borders), framed ("fit", vergence.stereospace.frame_cameras); then per eye S2's view plan (S2 §3.1,
// vergence.stereospace.mls_view.render_source_set): the 4 nearest sources, the proxy depth (median depth of the
// points in front), one handle per 4 px cell of the target, the MLS similarity map (Schaefer et al. 2006 §2.2,
// _mls_kernels.mls_similarity_points) and the angle penalty P_ANG (S2 Eq. (4)) at the grid nodes.
// stereospace_gl.js blends the sources per pixel from these nodes. Matrices are row-major arrays of 9.
const SSCams = (() => {
  // vergence.depth.rectify: samples per image edge of the extents, the largest area growth
  const EDGE_SAMPLES = 64, MAX_AREA_GROWTH = 16, MIN_AXIS_SINE = 1e-6;

  const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
  const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
  const sub = (a, b) => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
  const norm = (a) => Math.hypot(a[0], a[1], a[2]);
  const row = (M, r) => [M[3 * r], M[3 * r + 1], M[3 * r + 2]];
  const mulv = (M, v) => [0, 1, 2].map((r) => M[3 * r] * v[0] + M[3 * r + 1] * v[1] + M[3 * r + 2] * v[2]);
  function mul(A, B) {
    const C = new Array(9);
    for (let r = 0; r < 3; r++) {
      for (let c = 0; c < 3; c++) C[3 * r + c] = A[3 * r] * B[c] + A[3 * r + 1] * B[3 + c] + A[3 * r + 2] * B[6 + c];
    }
    return C;
  }
  const transpose = (M) => [M[0], M[3], M[6], M[1], M[4], M[7], M[2], M[5], M[8]];
  function inverse(M) {
    const [a, b, c, d, e, f, g, h, i] = M;
    const A = e * i - f * h, B = f * g - d * i, C = d * h - e * g;
    const det = a * A + b * B + c * C;
    return [A / det, (c * h - b * i) / det, (b * f - c * e) / det, B / det, (a * i - c * g) / det,
      (c * d - a * f) / det, C / det, (b * g - a * h) / det, (a * e - b * d) / det];
  }
  // Python's round(): halves to even (the views' height, width * H / W)
  function roundHalfEven(v) {
    const f = Math.floor(v), d = v - f;
    if (d > 0.5) return f + 1;
    if (d < 0.5) return f;
    return f % 2 === 0 ? f : f + 1;
  }

  // a camera {K, R, t, width, height, center}; x_cam = R x_world + t, centre -R^T t
  function camera(K, R, t, width, height) {
    return { K, R, t, width, height, center: mulv(transpose(R), t).map((v) => -v) };
  }
  const atCentre = (K, R, centre, width, height) => camera(K, R, mulv(R, centre).map((v) => -v), width, height);

  // rotation matrix <-> unit quaternion (w, x, y, z)
  function quaternion(R) {
    const [m00, m01, m02, m10, m11, m12, m20, m21, m22] = R;
    const tr = m00 + m11 + m22;
    let q;
    if (tr > 0) {
      const s = 2 * Math.sqrt(tr + 1);
      q = [s / 4, (m21 - m12) / s, (m02 - m20) / s, (m10 - m01) / s];
    } else if (m00 > m11 && m00 > m22) {
      const s = 2 * Math.sqrt(1 + m00 - m11 - m22);
      q = [(m21 - m12) / s, s / 4, (m01 + m10) / s, (m02 + m20) / s];
    } else if (m11 > m22) {
      const s = 2 * Math.sqrt(1 + m11 - m00 - m22);
      q = [(m02 - m20) / s, (m01 + m10) / s, s / 4, (m12 + m21) / s];
    } else {
      const s = 2 * Math.sqrt(1 + m22 - m00 - m11);
      q = [(m10 - m01) / s, (m02 + m20) / s, (m12 + m21) / s, s / 4];
    }
    const n = Math.hypot(...q);
    return q.map((v) => v / n);
  }
  function rotation([w, x, y, z]) {
    return [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w),
      2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w),
      2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)];
  }
  // slerp along the shorter arc (scipy's Slerp of two rotations)
  function slerp(Ra, Rb, s) {
    const a = quaternion(Ra);
    let b = quaternion(Rb);
    let c = a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3];
    if (c < 0) { b = b.map((v) => -v); c = -c; }
    const angle = Math.acos(Math.min(1, c));
    if (angle < 1e-12) return rotation(a);
    const wa = Math.sin((1 - s) * angle) / Math.sin(angle), wb = Math.sin(s * angle) / Math.sin(angle);
    return rotation(a.map((v, k) => wa * v + wb * b[k]));
  }

  // vergence.camera.interpolate: the endpoints themselves at 0 and 1
  function interpolate(a, b, s) {
    if (s <= 0) return a;
    if (s >= 1) return b;
    const centre = a.center.map((v, k) => (1 - s) * v + s * b.center[k]);
    return atCentre(a.K.map((v, k) => (1 - s) * v + s * b.K[k]), slerp(a.R, b.R, s), centre, a.width, a.height);
  }

  // the scene's cameras as objects, and each camera's projection of the points with what it sees
  function prepare(scene) {
    const cams = scene.cameras.map((c) => camera(c.K, c.R, c.t, c.width, c.height));
    const P = scene.points.length / 3;
    const projected = cams.map((cam) => {
      const { pixels, depth } = project(cam, scene.points);
      const seen = new Uint8Array(P);
      for (let p = 0; p < P; p++) {
        const x = pixels[2 * p], y = pixels[2 * p + 1];
        seen[p] = depth[p] > 0 && x >= -0.5 && x <= cam.width - 0.5 && y >= -0.5 && y <= cam.height - 0.5 ? 1 : 0;
      }
      return { pixels, seen };
    });
    return { ...scene, cams, projected, count: P };
  }

  // Camera.project: pixels (NaN behind) and camera-frame depth
  function project(cam, points) {
    const P = points.length / 3, pixels = new Float64Array(2 * P), depth = new Float64Array(P);
    const { K, R, t } = cam;
    for (let p = 0; p < P; p++) {
      const X = points[3 * p], Y = points[3 * p + 1], Z = points[3 * p + 2];
      const x = R[0] * X + R[1] * Y + R[2] * Z + t[0], y = R[3] * X + R[4] * Y + R[5] * Z + t[1];
      const z = R[6] * X + R[7] * Y + R[8] * Z + t[2];
      const u = K[0] * x + K[1] * y + K[2] * z, v = K[3] * x + K[4] * y + K[5] * z, w = K[6] * x + K[7] * y + K[8] * z;
      depth[p] = z;
      pixels[2 * p] = z > 0 ? u / w : NaN;
      pixels[2 * p + 1] = z > 0 ? v / w : NaN;
    }
    return { pixels, depth };
  }

  // the first and second eye's cameras of a state (vergence.stereospace.pair_cameras)
  function eyeCameras(scene, state) {
    const [i, j] = state.region, seg = scene.segment_cameras, cams = scene.cams;
    return [interpolate(cams[seg[i][0]], cams[seg[i][1]], state.li),
      interpolate(cams[seg[j][0]], cams[seg[j][1]], state.lj)];
  }

  // vergence.stereospace.eye_order: whether the left eye is the second
  function eyeOrder(first, second, up, minCosine) {
    const baseline = sub(second.center, first.center);
    const r2 = cross(row(first.R, 2), baseline), n = norm(r2);
    const cosine = n > 0 ? dot(r2, up) / n : 0;
    if (Math.abs(cosine) >= minCosine) return cosine > 0;
    return dot(baseline, row(first.R, 0)) < 0;
  }

  function extent(cam, T) {
    const x0 = -0.5, x1 = cam.width - 0.5, y0 = -0.5, y1 = cam.height - 0.5;
    const out = [Infinity, -Infinity, Infinity, -Infinity];
    const at = (x, y) => {
      const h = mulv(T, [x, y, 1]);
      if (!(h[2] > 0)) {
        throw new Error("this pair cannot be rectified: part of an image maps behind the rectified camera");
      }
      const u = h[0] / h[2], v = h[1] / h[2];
      out[0] = Math.min(out[0], u); out[1] = Math.max(out[1], u);
      out[2] = Math.min(out[2], v); out[3] = Math.max(out[3], v);
    };
    for (let k = 0; k < EDGE_SAMPLES; k++) {
      const s = k / (EDGE_SAMPLES - 1), xs = x0 + s * (x1 - x0), ys = y0 + s * (y1 - y0);
      at(xs, y0); at(xs, y1); at(x0, ys); at(x1, ys);
    }
    return out;
  }

  // vergence.depth.rectify_cameras (left, right already ordered), common_principal_point False
  function rectify(left, right) {
    const v1 = sub(right.center, left.center), baseline = norm(v1);
    const r1 = v1.map((v) => v / baseline);
    const v2 = cross(row(left.R, 2), r1);
    if (norm(v2) < MIN_AXIS_SINE) throw new Error("the baseline is along the viewing direction: no rectification");
    const r2 = v2.map((v) => v / norm(v2)), r3 = cross(r1, r2);
    const R = [...r1, ...r2, ...r3];
    const A = left.K.map((v, k) => (v + right.K[k]) / 2);
    A[1] = 0; A[2] = 0; A[5] = 0;
    const T = (cam) => mul(mul(mul(A, R), transpose(cam.R)), inverse(cam.K));
    const el = extent(left, T(left)), er = extent(right, T(right));
    const y0 = Math.min(el[2], er[2]), y1 = Math.max(el[3], er[3]);
    const height = Math.max(1, Math.ceil(y1 - y0 - 1e-9));
    const cy = -0.5 - y0 + (height - (y1 - y0)) / 2;
    const wl = el[1] - el[0], wr = er[1] - er[0];
    const width = Math.max(1, Math.ceil(Math.max(wl, wr) - 1e-9));
    if (width * height > MAX_AREA_GROWTH * Math.max(left.width * left.height, right.width * right.height)) {
      throw new Error("this pair cannot be rectified: the epipole is in or near the image");
    }
    const cx = [-0.5 - el[0] + (width - wl) / 2, -0.5 - er[0] + (width - wr) / 2];
    return [left, right].map((cam, k) => {
      const K = A.slice();
      K[2] = cx[k]; K[5] = cy;
      return atCentre(K, R, cam.center, width, height);
    });
  }

  // frame_cameras' _scaled: the image scaled by s about pixel centres, offset by (ox, oy)
  function scaled(cam, s, ox, oy, width, height) {
    const M = [s, 0, (s - 1) / 2 + ox, 0, s, (s - 1) / 2 + oy, 0, 0, 1];
    return camera(mul(M, cam.K), cam.R, cam.t, width, height);
  }

  // the (left, right) cameras of stereo_pair's views at a working width (framing "fit", no display shift)
  function pairCameras(scene, first, second, width) {
    const height = Math.max(1, roundHalfEven(first.height * width / first.width));
    const baseline = norm(sub(second.center, first.center));
    if (baseline <= scene.tolerance) {  // coincident eyes: the novel camera, framed "crop"
      const s = width / first.width;
      const cam = width === first.width && height === first.height ? first
        : scaled(first, s, (width - s * first.width) / 2, (height - s * first.height) / 2, width, height);
      return { left: cam, right: cam, swapped: false, coincident: true };
    }
    const swapped = eyeOrder(first, second, scene.up, scene.render.up_min_cosine);
    const [l, r] = rectify(swapped ? second : first, swapped ? first : second);
    const s = Math.min(width / l.width, height / l.height);
    const ox = (width - s * l.width) / 2, oy = (height - s * l.height) / 2;
    return { left: scaled(l, s, ox, oy, width, height), right: scaled(r, s, ox, oy, width, height), swapped,
      coincident: false };
  }

  const gridNodes = (n, step) => {
    const out = [];
    for (let v = 0; v < n; v += step) out.push(v);
    if (out[out.length - 1] !== n - 1) out.push(n - 1);
    return out;
  };

  // the sources' handles: of the points seen by the source and in front of the target, the first (in order) in
  // each cell x cell square of the target (_mls_view_kernels.select_handles)
  function handles(seen, inFront, q, cell) {
    const taken = new Set(), out = [];
    for (let p = 0; p < inFront.length; p++) {
      if (!seen[p] || !inFront[p]) continue;
      const kx = Math.floor(q[2 * p] / cell), ky = Math.floor(q[2 * p + 1] / cell);
      // one number per cell while |kx|, |ky| < 2^20 (a million cells out); a string beyond
      const key = Math.abs(kx) < 1048576 && Math.abs(ky) < 1048576
        ? (kx + 1048576) * 2097152 + ky + 1048576 : `${kx},${ky}`;
      if (taken.has(key)) continue;
      taken.add(key);
      out.push(p);
    }
    return out;
  }

  // the MLS similarity map (handles q -> p) at a point v (Schaefer et al. 2006, alpha 1: w = 1 / |q - v|^2)
  function mlsAt(vx, vy, hs, n, out, o) {  // hs: (qx, qy, px, py) per handle
    let sw = 0, sax = 0, say = 0, sbx = 0, sby = 0, sab = 0, sac = 0;
    for (let h = 0; h < 4 * n; h += 4) {
      const ax = hs[h] - vx, ay = hs[h + 1] - vy, bx = hs[h + 2] - vx, by = hs[h + 3] - vy;
      const w = 1 / (ax * ax + ay * ay);
      sw += w; sax += w * ax; say += w * ay; sbx += w * bx; sby += w * by;
      sab += w * (ax * bx + ay * by); sac += w * (ax * by - ay * bx);
    }
    const psx = sax / sw, psy = say / sw, qsx = sbx / sw, qsy = sby / sw;
    const mu = n - sw * (psx * psx + psy * psy);  // sum of w |a|^2 = n (alpha 1)
    if (!(sw < Infinity && mu > 0)) {  // on a handle: its target, the limit of the formula
      let best = Infinity, hb = 0;
      for (let h = 0; h < 4 * n; h += 4) {
        const d = (hs[h] - vx) ** 2 + (hs[h + 1] - vy) ** 2;
        if (d < best) { best = d; hb = h; }
      }
      out[o] = hs[hb + 2]; out[o + 1] = hs[hb + 3];
      return;
    }
    const ar = (sab - sw * (psx * qsx + psy * qsy)) / mu, ai = (sac - sw * (psx * qsy - psy * qsx)) / mu;
    out[o] = vx + qsx - psx * ar + psy * ai;
    out[o + 1] = vy + qsy - psx * ai - psy * ar;
  }

  // S2's view plan of a target camera: the sources (camera index or -1: too few handles), the node columns and
  // rows, each used source's handles (qx, qy, px, py; Float32Array, source after source, from offsets[s]), and,
  // with maps (else the GPU's MLS pass makes them), per source and node (u, v, P_ANG, 0) as a Float32Array
  // (source-major, then rows, then columns)
  function viewPlan(scene, target, maps = true) {
    const r = scene.render, P = scene.count;
    const order = scene.cams.map((c, k) => [norm(sub(c.center, target.center)), k]);
    order.sort((a, b) => a[0] - b[0] || a[1] - b[1]);
    const ids = order.slice(0, r.sources).map(([, k]) => k);
    const { pixels: q, depth } = project(target, scene.points);
    const inFront = new Uint8Array(P), zs = [];
    for (let p = 0; p < P; p++) if (depth[p] > 0) { inFront[p] = 1; zs.push(depth[p]); }
    if (!zs.length) throw new Error("no sparse point lies in front of this view");
    zs.sort((a, b) => a - b);
    const m = zs.length >> 1, proxy = zs.length % 2 ? zs[m] : (zs[m - 1] + zs[m]) / 2;
    const xs = gridNodes(target.width, r.grid_step), ys = gridNodes(target.height, r.grid_step);
    const nx = xs.length, ny = ys.length, S = ids.length;
    const nodes = new Float32Array(S * ny * nx * 4), tmp = new Float64Array(2);
    const Kinv = inverse(target.K), Rt = transpose(target.R), c = target.center;
    const used = ids.slice(), counts = [], sets = [];
    for (let s = 0; s < S; s++) {
      const n = ids[s], src = scene.projected[n], chosen = handles(src.seen, inFront, q, r.handle_cell_px);
      counts.push(chosen.length);
      if (chosen.length < r.min_handles) { used[s] = -1; sets.push(new Float64Array(0)); continue; }
      const hs = new Float64Array(4 * chosen.length);
      chosen.forEach((p, h) => {
        hs[4 * h] = q[2 * p]; hs[4 * h + 1] = q[2 * p + 1];
        hs[4 * h + 2] = src.pixels[2 * p]; hs[4 * h + 3] = src.pixels[2 * p + 1];
      });
      sets.push(hs);
      if (!maps) continue;
      const cs = scene.cams[n].center;
      for (let j = 0; j < ny; j++) {
        for (let i = 0; i < nx; i++) {
          const o = 4 * ((s * ny + j) * nx + i);
          mlsAt(xs[i], ys[j], hs, chosen.length, tmp, 0);
          // P_ANG at the node's proxy point P = c + depth R^T K^-1 (x, y, 1) (_mls_view_kernels.node_angles)
          const rx = Kinv[0] * xs[i] + Kinv[1] * ys[j] + Kinv[2], ry = Kinv[3] * xs[i] + Kinv[4] * ys[j] + Kinv[5];
          const rz = Kinv[6] * xs[i] + Kinv[7] * ys[j] + Kinv[8];
          const ax = -proxy * (Rt[0] * rx + Rt[1] * ry + Rt[2] * rz);
          const ay = -proxy * (Rt[3] * rx + Rt[4] * ry + Rt[5] * rz);
          const az = -proxy * (Rt[6] * rx + Rt[7] * ry + Rt[8] * rz);  // a = c - P
          const bx = cs[0] - c[0] + ax, by = cs[1] - c[1] + ay, bz = cs[2] - c[2] + az;  // b = c_s - P
          const cx = ay * bz - az * by, cy = az * bx - ax * bz, cz = ax * by - ay * bx;
          nodes[o] = tmp[0]; nodes[o + 1] = tmp[1];
          nodes[o + 2] = Math.atan2(Math.sqrt(cx * cx + cy * cy + cz * cz), ax * bx + ay * by + az * bz);
        }
      }
    }
    if (!used.some((u) => u >= 0)) throw new Error(`no source sees ${r.min_handles} of the points of this view`);
    const offsets = [0];
    sets.forEach((hs) => offsets.push(offsets[offsets.length - 1] + hs.length / 4));
    const handleData = new Float32Array(4 * offsets[S]);
    sets.forEach((hs, s) => handleData.set(hs, 4 * offsets[s]));
    return { ids: used, counts, xs, ys, nodes: maps ? nodes : null, proxy, handles: handleData, offsets, Kinv, Rt };
  }

  return { prepare, project, interpolate, eyeCameras, eyeOrder, rectify, pairCameras, viewPlan, roundHalfEven };
})();
