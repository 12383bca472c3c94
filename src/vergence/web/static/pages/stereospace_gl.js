"use strict";

// ---------------------------------------------------------------- StereoSpace in the browser: the WebGL2 renderer
// Draws the stereo pair of any state from the job's scene (GET /api/stereospace/{job}/scene): stereospace_cams.js
// makes each eye's cameras and S2's view plan (sources, MLS maps and angle penalties at the grid nodes); the node
// grid drawn as triangles and a fragment shader do _mls_view_kernels.render_view's per-pixel pass (the node values
// bilinear, P = max(floor, P_ANG) where the map lands on the source, else infinite; ULR weights over the k best,
// Buehler et al. 2001; the sources sampled bilinearly with edge pixels repeated) into one texture per eye; a
// second pass packs the eyes for the display (side by side, top-bottom, cross-eyed, anaglyphs).
const SSGL = (() => {
  // the layouts drawn here (vergence.display.pack's names); the others are the server's
  const FORMATS = ["anaglyph", "anaglyph-red-cyan", "sbs", "cross-eyed", "tb"];
  const MAX_SOURCES = 4;
  const VERTEX = `#version 300 es
in vec2 corner;
void main() { gl_Position = vec4(corner, 0.0, 1.0); }`;
  // The node grid drawn cell row by cell row (an instance per row, a triangle strip along it; no vertex buffer:
  // gl_VertexID, gl_InstanceID). Each vertex carries, per source, the node values (u, v, P_ANG) on the row's top
  // edge (a) and its bottom edge minus the top (d) at the vertex's column: both affine in x inside a cell and
  // equal at a column's top and bottom vertices, so the rasteriser's interpolation gives each pixel exactly the
  // bilinear value a + t d, t the pixel's fraction of the row. Vertices sit at pixel centres (pixel x's centre
  // x + 0.5 at fraction (x - x0) / (x1 - x0) of its cell, as the kernel's), the outer ones on the frame's edges
  // with their values extrapolated along the cell. u and v are handed on as texture coordinates of the source,
  // ((u, v) + 0.5) / (w, h): on the source where both lie in [0, 1]; a source left out lies far outside. (A
  // full-frame pass whose pixels read the 4 sources' nodes from a float texture took a third longer on SwiftShader.)
  const GRID = `#version 300 es
precision highp float; precision highp int;
uniform highp sampler2D nodes;  // (nx, ny * 4): (u, v, P_ANG, 0) per node and source
uniform int nx, ny, step, width, height;
uniform float lastX, lastY;
uniform vec4 used, iw, ih;  // per source: 1 where drawn from; 1 / its width, height
out float t;
out vec4 au, av, ap, du, dv, dp;  // per source (one per component): u, v, P_ANG on the top edge; bottom - top
vec4 node(int s, int i, int j) { return texelFetch(nodes, ivec2(i, s * ny + j), 0); }
void main() {
  int j = gl_InstanceID, i = gl_VertexID >> 1, bottom = gl_VertexID & 1, c = min(i, nx - 2);
  float x0 = float(c * step), x1 = c + 1 == nx - 1 ? lastX : float((c + 1) * step);
  float y0 = float(j * step), y1 = j + 1 == ny - 1 ? lastY : float((j + 1) * step);
  float X = i == 0 ? 0.0 : i == nx - 1 ? float(width) : x0 + 0.5;
  float Y = bottom == 0 ? (j == 0 ? 0.0 : y0 + 0.5) : (j + 1 == ny - 1 ? float(height) : y1 + 0.5);
  float fx = (X - 0.5 - x0) / (x1 - x0);
  t = (Y - 0.5 - y0) / (y1 - y0);
  vec4 top[4], bot[4];
  for (int s = 0; s < 4; s++) {
    top[s] = mix(node(s, c, j), node(s, c + 1, j), fx);
    bot[s] = mix(node(s, c, j + 1), node(s, c + 1, j + 1), fx) - top[s];
  }
  au = mix(vec4(-2.0), (vec4(top[0].x, top[1].x, top[2].x, top[3].x) + 0.5) * iw, used);
  av = (vec4(top[0].y, top[1].y, top[2].y, top[3].y) + 0.5) * ih;
  ap = vec4(top[0].z, top[1].z, top[2].z, top[3].z);
  du = vec4(bot[0].x, bot[1].x, bot[2].x, bot[3].x) * iw * used;
  dv = vec4(bot[0].y, bot[1].y, bot[2].y, bot[3].y) * ih;
  dp = vec4(bot[0].z, bot[1].z, bot[2].z, bot[3].z);
  gl_Position = vec4(2.0 * X / float(width) - 1.0, 1.0 - 2.0 * Y / float(height), 0.0, 1.0);
}`;
  // Each source's pixels read by the texture unit's bilinear filter (one fetch, a texture per source image;
  // CLAMP_TO_EDGE repeats the edge pixels over their outer half as the kernel's taps do; the filter's weights are
  // the texture unit's, GPUs' in 8-bit subtexel steps, 1/256 of a texel). K (the scene's k) is compiled in: with
  // k = 4 of 4 sources the k-th smallest penalty is the largest, no sort. On SwiftShader every operation of a
  // pixel counts (docs/stereospace.md, "Where a still frame's time goes"): a branch is skipped only where no
  // pixel of a 2 x 2 quad takes it, and the clamps of the source positions to each source's size, read from a
  // uniform array indexed by the source, took a quarter to a third of the pass.
  const RENDER = (k) => `#version 300 es
precision highp float; precision highp int;
#define K ${k}
uniform sampler2D image0, image1, image2, image3;
uniform float floorP, scale, negligible;
in float t;
in vec4 au, av, ap, du, dv, dp;
out vec4 colour;
const float NONE = 1e30;  // the penalty of a source without a sample here (P_FOV infinite)
vec3 colourOf(sampler2D image, vec2 uv, float wn) {
  if (wn <= negligible) return vec3(0.0);
  return wn * textureLod(image, uv, 0.0).rgb;
}
void main() {
  vec4 u = au + t * du, v = av + t * dv, p = max(vec4(floorP), ap + t * dp);
  vec4 valid = vec4(greaterThanEqual(min(min(u, 1.0 - u), min(v, 1.0 - v)), vec4(0.0)));
  float m = dot(valid, vec4(1.0));
#if K >= 4
  // m >= k: all four valid, P_(k) the largest (k > 4: never, equal weights)
  vec4 w = m >= float(K) ? max(vec4(0.0), 1.0 - p * (1.0 / (scale * max(max(p.x, p.y), max(p.z, p.w))))) : valid;
#else
  vec4 pen = mix(vec4(NONE), p, bvec4(valid)), w = valid;
  if (m >= float(K)) {  // the k-th smallest penalty (a sorting network of 4)
    float a = min(pen.x, pen.y), b = max(pen.x, pen.y), c = min(pen.z, pen.w), d = max(pen.z, pen.w);
    float lo = min(a, c), hi = max(b, d), e = max(a, c), f = min(b, d);
    float kth = vec4(lo, min(e, f), max(e, f), hi)[K - 1];
    w = valid * max(vec4(0.0), 1.0 - pen * (1.0 / (scale * kth)));
  }
#endif
  float total = dot(w, vec4(1.0));
  vec4 wn = w * (total > 0.0 ? 1.0 / total : 0.0);
  colour = vec4(colourOf(image0, vec2(u.x, v.x), wn.x) + colourOf(image1, vec2(u.y, v.y), wn.y)
                + colourOf(image2, vec2(u.z, v.z), wn.z) + colourOf(image3, vec2(u.w, v.w), wn.w), 1.0);
}`;
  // The MLS maps and P_ANG at the grid nodes on the GPU (EXT_color_buffer_float): one fragment per node and source
  // of a (nx, ny * S) float target; the handles (qx, qy, px, py) in a float texture, HANDLE_ROW a row. As
  // _mls_kernels.mls_similarity_points (float32, alpha 1: w = 1 / |q - v|^2; on a handle, its target) and
  // _mls_view_kernels.node_angles (the angle at the node's proxy point, atan2 of |a x b| and a . b).
  const HANDLE_ROW = 1024;
  const MLS = `#version 300 es
precision highp float; precision highp int;
uniform highp sampler2D handles;
uniform int offset[5], used[4];
uniform int nx, ny, step;
uniform float lastX, lastY, proxy;
uniform mat3 Kinv, Rt;
uniform vec3 centre, sourceCentre[4];
out vec4 node;
vec4 handle(int h) { return texelFetch(handles, ivec2(h % ${HANDLE_ROW}, h / ${HANDLE_ROW}), 0); }
void main() {
  int i = int(gl_FragCoord.x), s = int(gl_FragCoord.y) / ny, j = int(gl_FragCoord.y) % ny;
  if (used[s] == 0) { node = vec4(0.0); return; }
  float vx = i == nx - 1 ? lastX : float(i * step), vy = j == ny - 1 ? lastY : float(j * step);
  float sw = 0.0, sax = 0.0, say = 0.0, sbx = 0.0, sby = 0.0, sab = 0.0, sac = 0.0;
  int first = offset[s], last = offset[s + 1];
  for (int h = first; h < last; h++) {
    vec4 t = handle(h);
    float ax = t.x - vx, ay = t.y - vy, bx = t.z - vx, by = t.w - vy;
    float w = 1.0 / (ax * ax + ay * ay);
    sw += w; sax += w * ax; say += w * ay; sbx += w * bx; sby += w * by;
    sab += w * (ax * bx + ay * by); sac += w * (ax * by - ay * bx);
  }
  float psx = sax / sw, psy = say / sw, qsx = sbx / sw, qsy = sby / sw;
  float mu = float(last - first) - sw * (psx * psx + psy * psy);
  vec2 uv;
  if (!(sw < 3.0e38 && mu > 0.0)) {
    float best = 3.4e38;
    for (int h = first; h < last; h++) {
      vec4 t = handle(h);
      float d = (t.x - vx) * (t.x - vx) + (t.y - vy) * (t.y - vy);
      if (d < best) { best = d; uv = t.zw; }
    }
  } else {
    float ar = (sab - sw * (psx * qsx + psy * qsy)) / mu, ai = (sac - sw * (psx * qsy - psy * qsx)) / mu;
    uv = vec2(vx + qsx - psx * ar + psy * ai, vy + qsy - psx * ai - psy * ar);
  }
  vec3 a = -proxy * (Rt * (Kinv * vec3(vx, vy, 1.0))), b = sourceCentre[s] - centre + a;
  node = vec4(uv, atan(length(cross(a, b)), dot(a, b)), 0.0);
}`;
  // the eyes packed for the display: layout 0 anaglyph (Dubois red-cyan in linear light), 1 red-cyan, 2 sbs,
  // 3 cross-eyed, 4 tb (vergence.display.pack); a program per layout (the anaglyph's pass a quarter faster than
  // one program choosing among the layouts per pixel)
  const PACK = (layout) => `#version 300 es
precision highp float;
#define LAYOUT ${layout}
uniform sampler2D left, right;
uniform int width, height;
out vec4 colour;
vec3 lin(vec3 c) { return mix(c / 12.92, pow((c + 0.055) / 1.055, vec3(2.4)), step(vec3(0.04045), c)); }
vec3 srgb(vec3 c) { return mix(12.92 * c, 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055, step(vec3(0.0031308), c)); }
void main() {
  ivec2 p = ivec2(gl_FragCoord.xy);  // the eyes' textures and the canvas both bottom row first
#if LAYOUT == 0
  const mat3 ml = transpose(mat3(0.437, 0.449, 0.164, -0.062, -0.062, -0.024, -0.048, -0.050, -0.017));
  const mat3 mr = transpose(mat3(-0.011, -0.032, -0.007, 0.377, 0.761, 0.009, -0.026, -0.093, 1.234));
  vec3 l = lin(texelFetch(left, p, 0).rgb), r = lin(texelFetch(right, p, 0).rgb);
  colour = vec4(srgb(clamp(ml * l + mr * r, 0.0, 1.0)), 1.0);
#elif LAYOUT == 1
  colour = vec4(texelFetch(left, p, 0).r, texelFetch(right, p, 0).gb, 1.0);
#elif LAYOUT == 4
  colour = vec4(p.y >= height ? texelFetch(left, p - ivec2(0, height), 0).rgb : texelFetch(right, p, 0).rgb, 1.0);
#else
  ivec2 q = ivec2(p.x % width, p.y);
  colour = vec4((p.x < width) == (LAYOUT == 2) ? texelFetch(left, q, 0).rgb : texelFetch(right, q, 0).rgb, 1.0);
#endif
}`;

  function compile(gl, vs, fs) {
    const program = gl.createProgram();
    for (const [type, text] of [[gl.VERTEX_SHADER, vs], [gl.FRAGMENT_SHADER, fs]]) {
      const shader = gl.createShader(type);
      gl.shaderSource(shader, text);
      gl.compileShader(shader);
      if (!gl.getShaderParameter(shader, gl.COMPILE_STATUS)) throw new Error(`shader: ${gl.getShaderInfoLog(shader)}`);
      gl.attachShader(program, shader);
    }
    gl.bindAttribLocation(program, 0, "corner");
    gl.linkProgram(program);
    for (const shader of gl.getAttachedShaders(program)) gl.deleteShader(shader);  // freed with the program
    if (!gl.getProgramParameter(program, gl.LINK_STATUS)) throw new Error(`program: ${gl.getProgramInfoLog(program)}`);
    return program;
  }

  function texture(gl, target, filter = gl.NEAREST) {
    const tex = gl.createTexture();
    gl.bindTexture(target, tex);
    for (const [p, v] of [[gl.TEXTURE_MIN_FILTER, filter], [gl.TEXTURE_MAG_FILTER, filter],
      [gl.TEXTURE_WRAP_S, gl.CLAMP_TO_EDGE], [gl.TEXTURE_WRAP_T, gl.CLAMP_TO_EDGE]]) gl.texParameteri(target, p, v);
    return tex;
  }

  async function loadImage(url) {
    const img = new Image();
    img.src = url;
    await img.decode();
    return img;
  }

  // a renderer on a canvas, or null without WebGL2
  function create(canvas) {
    const gl = canvas.getContext("webgl2",
      { antialias: false, preserveDrawingBuffer: true, premultipliedAlpha: false });
    if (!gl) return null;
    const packs = FORMATS.map((_, layout) => compile(gl, VERTEX, PACK(layout)));
    const renders = new Map();  // the blend's program per k, compiled when a scene first needs it
    const renderFor = (k) => {
      if (!renders.has(k)) renders.set(k, compile(gl, GRID, RENDER(k)));
      return renders.get(k);
    };
    const quad = gl.createBuffer();
    gl.bindBuffer(gl.ARRAY_BUFFER, quad);
    gl.bufferData(gl.ARRAY_BUFFER, new Float32Array([-1, -1, 1, -1, -1, 1, 1, 1]), gl.STATIC_DRAW);
    gl.enableVertexAttribArray(0);
    gl.vertexAttribPointer(0, 2, gl.FLOAT, false, 0, 0);
    const loc = (p, n) => gl.getUniformLocation(p, n);
    // each eye's own textures (one eye's passes never wait on the other's), re-allocated only when a size changes
    const eyes = [0, 1].map(() => ({ tex: texture(gl, gl.TEXTURE_2D), fbo: gl.createFramebuffer(), width: 0, height: 0,
      nodes: texture(gl, gl.TEXTURE_2D), nodesFbo: gl.createFramebuffer(), nodeSize: "",
      handles: texture(gl, gl.TEXTURE_2D), handleRows: 0 }));
    // the maps on the GPU where float targets render, else in JavaScript (stereospace_cams.js)
    const mls = gl.getExtension("EXT_color_buffer_float") ? compile(gl, VERTEX, MLS) : null;
    const renderer = gl.getExtension("WEBGL_debug_renderer_info");
    const name = gl.getParameter(renderer ? renderer.UNMASKED_RENDERER_WEBGL : gl.RENDERER);
    // a software "GPU" (SwiftShader, llvmpipe) runs the MLS pass slower than JavaScript does (kermit, 320 px: a
    // frame 144-177 ms against 101-113 ms, benchmarks/stereospace_browser.py --maps): the maps in JavaScript there
    let gpuMaps = mls !== null && !/swiftshader|llvmpipe|software/i.test(name);
    let images = null, scene = null;  // a texture per source image
    const finish = () => gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, new Uint8Array(4));

    async function load(sceneJson) {
      if (images) images.forEach((tex) => gl.deleteTexture(tex));  // a scene loaded before on this renderer
      images = null;
      scene = SSCams.prepare(sceneJson);
      const imgs = await Promise.all(sceneJson.images.map(loadImage));
      gl.pixelStorei(gl.UNPACK_COLORSPACE_CONVERSION_WEBGL, gl.NONE);
      gl.pixelStorei(gl.UNPACK_PREMULTIPLY_ALPHA_WEBGL, false);
      gl.pixelStorei(gl.UNPACK_FLIP_Y_WEBGL, false);
      images = imgs.map((img) => {
        const tex = texture(gl, gl.TEXTURE_2D, gl.LINEAR);
        gl.texStorage2D(gl.TEXTURE_2D, 1, gl.RGBA8, img.naturalWidth, img.naturalHeight);
        gl.texSubImage2D(gl.TEXTURE_2D, 0, 0, 0, img.naturalWidth, img.naturalHeight, gl.RGBA, gl.UNSIGNED_BYTE, img);
        return tex;
      });
      scene.sizes = imgs.map((i) => [i.naturalWidth, i.naturalHeight]);
      return scene;
    }

    // the float texture of an eye's node values (nx, ny * S), and its frame buffer for the MLS pass
    function nodeTexture(eye, nx, rows, data) {
      gl.bindTexture(gl.TEXTURE_2D, eye.nodes);
      if (eye.nodeSize !== `${nx}x${rows}`) {
        gl.texImage2D(gl.TEXTURE_2D, 0, gl.RGBA32F, nx, rows, 0, gl.RGBA, gl.FLOAT, data);
        eye.nodeSize = `${nx}x${rows}`;
        if (mls) {
          gl.bindFramebuffer(gl.FRAMEBUFFER, eye.nodesFbo);
          gl.framebufferTexture2D(gl.FRAMEBUFFER, gl.COLOR_ATTACHMENT0, gl.TEXTURE_2D, eye.nodes, 0);
        }
      } else if (data) gl.texSubImage2D(gl.TEXTURE_2D, 0, 0, 0, nx, rows, gl.RGBA, gl.FLOAT, data);
    }

    function gpuNodes(eye, plan, cam) {
      const r = scene.render, nx = plan.xs.length, ny = plan.ys.length, S = plan.ids.length;
      const n = Math.max(1, plan.offsets[S]), rows = Math.ceil(n / HANDLE_ROW);
      const data = new Float32Array(4 * HANDLE_ROW * rows);
      data.set(plan.handles);
      gl.bindTexture(gl.TEXTURE_2D, eye.handles);
      if (eye.handleRows !== rows) {
        gl.texImage2D(gl.TEXTURE_2D, 0, gl.RGBA32F, HANDLE_ROW, rows, 0, gl.RGBA, gl.FLOAT, data);
        eye.handleRows = rows;
      } else gl.texSubImage2D(gl.TEXTURE_2D, 0, 0, 0, HANDLE_ROW, rows, gl.RGBA, gl.FLOAT, data);
      nodeTexture(eye, nx, ny * S, null);
      gl.bindFramebuffer(gl.FRAMEBUFFER, eye.nodesFbo);
      gl.viewport(0, 0, nx, ny * S);
      gl.useProgram(mls);
      gl.activeTexture(gl.TEXTURE2);
      gl.bindTexture(gl.TEXTURE_2D, eye.handles);
      gl.uniform1i(loc(mls, "handles"), 2);
      gl.uniform1iv(loc(mls, "offset"), [0, 1, 2, 3, 4].map((s) => plan.offsets[Math.min(s, S)]));
      gl.uniform1iv(loc(mls, "used"), [0, 1, 2, 3].map((s) => (s < S && plan.ids[s] >= 0 ? 1 : 0)));
      for (const [name, v] of [["nx", nx], ["ny", ny], ["step", r.grid_step]]) gl.uniform1i(loc(mls, name), v);
      for (const [name, v] of [["lastX", plan.xs[nx - 1]], ["lastY", plan.ys[ny - 1]], ["proxy", plan.proxy]]) {
        gl.uniform1f(loc(mls, name), v);
      }
      gl.uniformMatrix3fv(loc(mls, "Kinv"), true, plan.Kinv);
      gl.uniformMatrix3fv(loc(mls, "Rt"), true, plan.Rt);
      gl.uniform3fv(loc(mls, "centre"), cam.center);
      gl.uniform3fv(loc(mls, "sourceCentre"), [0, 1, 2, 3].flatMap((s) => (s < S && plan.ids[s] >= 0
        ? scene.cams[plan.ids[s]].center : [0, 0, 0])));
      gl.drawArrays(gl.TRIANGLE_STRIP, 0, 4);
    }

    // the profile of a frame (drawCameras' last argument): each stage's milliseconds, the GPU waited for after each
    let profile = null, mark = 0;
    function stage(name) {
      if (!profile) return;
      finish();
      const now = performance.now();
      profile[name] = (profile[name] || 0) + now - mark;
      mark = now;
    }

    function drawEye(eye, cam) {
      const plan = SSCams.viewPlan(scene, cam, !gpuMaps), r = scene.render, nx = plan.xs.length, ny = plan.ys.length;
      stage(gpuMaps ? "plan" : "plan+maps");
      if (eye.width !== cam.width || eye.height !== cam.height) {
        gl.bindTexture(gl.TEXTURE_2D, eye.tex);
        gl.texImage2D(gl.TEXTURE_2D, 0, gl.RGBA8, cam.width, cam.height, 0, gl.RGBA, gl.UNSIGNED_BYTE, null);
        gl.bindFramebuffer(gl.FRAMEBUFFER, eye.fbo);
        gl.framebufferTexture2D(gl.FRAMEBUFFER, gl.COLOR_ATTACHMENT0, gl.TEXTURE_2D, eye.tex, 0);
        eye.width = cam.width; eye.height = cam.height;
      }
      if (gpuMaps) gpuNodes(eye, plan, cam);
      else nodeTexture(eye, nx, ny * plan.ids.length, plan.nodes);
      stage(gpuMaps ? "maps" : "upload");
      gl.bindFramebuffer(gl.FRAMEBUFFER, eye.fbo);
      gl.viewport(0, 0, cam.width, cam.height);
      const render = renderFor(r.k);
      gl.useProgram(render);
      gl.activeTexture(gl.TEXTURE1);
      gl.bindTexture(gl.TEXTURE_2D, eye.nodes);
      gl.uniform1i(loc(render, "nodes"), 1);
      const used = [0, 0, 0, 0], iw = [0, 0, 0, 0], ih = [0, 0, 0, 0];
      for (let s = 0; s < MAX_SOURCES; s++) {
        const n = s < plan.ids.length ? plan.ids[s] : -1;
        if (n >= 0) [used[s], iw[s], ih[s]] = [1, 1 / scene.sizes[n][0], 1 / scene.sizes[n][1]];
        gl.activeTexture(gl.TEXTURE2 + s);
        gl.bindTexture(gl.TEXTURE_2D, images[Math.max(0, n)]);  // a source left out: any image, never read
        gl.uniform1i(loc(render, `image${s}`), 2 + s);
      }
      for (const [name, v] of [["used", used], ["iw", iw], ["ih", ih]]) gl.uniform4fv(loc(render, name), v);
      for (const [name, v] of [["nx", nx], ["ny", ny], ["step", r.grid_step], ["width", cam.width],
        ["height", cam.height]]) {
        gl.uniform1i(loc(render, name), v);
      }
      for (const [name, v] of [["lastX", plan.xs[nx - 1]], ["lastY", plan.ys[ny - 1]], ["floorP", r.penalty_floor],
        ["scale", r.threshold_scale], ["negligible", r.negligible]]) {
        gl.uniform1f(loc(render, name), v);
      }
      gl.drawArraysInstanced(gl.TRIANGLE_STRIP, 0, 2 * nx, ny - 1);
      stage("blend");
      return plan;
    }

    // the pair of two eye cameras (the state's first and second) at a working width, packed on the canvas
    function drawCameras(first, second, width, format, times = null) {
      profile = times;
      mark = performance.now();
      const pair = SSCams.pairCameras(scene, first, second, width);
      stage("cameras");
      drawEye(eyes[0], pair.left);
      drawEye(eyes[1], pair.right);
      const layout = Math.max(0, FORMATS.indexOf(format)), w = pair.left.width, h = pair.left.height;
      const cw = layout === 2 || layout === 3 ? 2 * w : w, ch = layout === 4 ? 2 * h : h;
      // a new size only when it changes (else no reallocation)
      if (canvas.width !== cw || canvas.height !== ch) [canvas.width, canvas.height] = [cw, ch];
      gl.bindFramebuffer(gl.FRAMEBUFFER, null);
      gl.viewport(0, 0, canvas.width, canvas.height);
      const pack = packs[layout];
      gl.useProgram(pack);
      gl.activeTexture(gl.TEXTURE0);
      gl.bindTexture(gl.TEXTURE_2D, eyes[0].tex);
      gl.activeTexture(gl.TEXTURE1);
      gl.bindTexture(gl.TEXTURE_2D, eyes[1].tex);
      gl.uniform1i(loc(pack, "left"), 0);
      gl.uniform1i(loc(pack, "right"), 1);
      for (const [name, v] of [["width", w], ["height", h]]) gl.uniform1i(loc(pack, name), v);
      gl.drawArrays(gl.TRIANGLE_STRIP, 0, 4);
      stage("pack");
      profile = null;
      return pair;
    }

    // one eye's pixels, top row first, RGBA bytes as base64 (the tests' read-back)
    function readEye(k) {
      const eye = eyes[k], out = new Uint8Array(eye.width * eye.height * 4);
      gl.bindFramebuffer(gl.FRAMEBUFFER, eyes[k].fbo);
      gl.readPixels(0, 0, eye.width, eye.height, gl.RGBA, gl.UNSIGNED_BYTE, out);
      gl.bindFramebuffer(gl.FRAMEBUFFER, null);
      const rows = new Uint8Array(out.length), stride = 4 * eye.width;
      for (let y = 0; y < eye.height; y++) {
        rows.set(out.subarray(y * stride, (y + 1) * stride), (eye.height - 1 - y) * stride);
      }
      let text = "";
      for (let o = 0; o < rows.length; o += 0x8000) text += String.fromCharCode(...rows.subarray(o, o + 0x8000));
      return { width: eye.width, height: eye.height, rgba: btoa(text) };
    }

    // one eye as a PNG data URL (Enter VR's images when the page draws the pair)
    function eyeURL(k) {
      const shot = readEye(k), out = document.createElement("canvas");
      [out.width, out.height] = [shot.width, shot.height];
      const bytes = Uint8ClampedArray.from(atob(shot.rgba), (c) => c.charCodeAt(0));
      out.getContext("2d").putImageData(new ImageData(bytes, shot.width, shot.height), 0, 0);
      return out.toDataURL("image/png");
    }

    // where the MLS maps are made: "gpu" (when float targets render) or "js"; the tests compare both
    const maps = (where) => {
      if (where !== undefined) gpuMaps = where === "gpu" && mls !== null;
      return gpuMaps ? "gpu" : "js";
    };
    // every GL object this renderer made, and their deletion (the page disposes of a renderer before it makes
    // the next one on the same canvas: a second collection prepared)
    const objects = () => ({
      programs: [...renders.values(), ...packs, mls].filter(Boolean), buffers: [quad],
      framebuffers: eyes.flatMap((e) => [e.fbo, e.nodesFbo]),
      textures: [...(images || []), ...eyes.flatMap((e) => [e.tex, e.nodes, e.handles])],
    });
    function dispose() {
      const o = objects();
      o.programs.forEach((x) => gl.deleteProgram(x));
      o.buffers.forEach((x) => gl.deleteBuffer(x));
      o.framebuffers.forEach((x) => gl.deleteFramebuffer(x));
      o.textures.forEach((x) => gl.deleteTexture(x));
      images = null;
      scene = null;
    }
    return { gl, name, load, drawCameras, readEye, eyeURL, finish, maps, objects, dispose, scene: () => scene };
  }

  return { FORMATS, create };
})();
