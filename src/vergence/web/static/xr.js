// "Enter VR": the current stereo pair in a WebXR headset, where the browser offers immersive-vr.
//
// offerVR(container, getPair) appends an "Enter VR" button to container when
// navigator.xr.isSessionSupported("immersive-vr") says yes, and appends nothing otherwise (no headset,
// no WebXR, plain http on another host): the page never depends on it. getPair() returns
// {left: url, right: url}, the two views of the pair shown now. In the headset each eye sees its own
// view on a head-locked virtual screen (the same rectangle of each eye's viewport), as a stereoscope
// does: the pair's own disparities are what the eyes fuse. Select (trigger) or the page's button leaves.
"use strict";

const XR_SCREEN = 0.8;  // the virtual screen's half-width in each eye's normalised device coordinates

async function offerVR(container, getPair) {
  if (!navigator.xr || typeof navigator.xr.isSessionSupported !== "function") return null;
  let supported = false;
  try { supported = await navigator.xr.isSessionSupported("immersive-vr"); } catch (exc) { supported = false; }
  if (!supported) return null;
  const button = Object.assign(document.createElement("button"), { type: "button", textContent: "Enter VR" });
  button.dataset.testid = "enter-vr";
  button.addEventListener("click", async () => {
    try { await enterVR(getPair()); } catch (exc) { showError(`Enter VR: ${exc.message || exc}`); }
  });
  container.append(button);
  return button;
}

function xrImage(url) {
  return new Promise((resolve, reject) => {
    const img = new Image();
    img.onload = () => resolve(img);
    img.onerror = () => reject(new Error(`cannot load ${url}`));
    img.src = url;
  });
}

function xrProgram(gl) {
  const compile = (type, text) => {
    const shader = gl.createShader(type);
    gl.shaderSource(shader, text);
    gl.compileShader(shader);
    return shader;
  };
  const program = gl.createProgram();
  gl.attachShader(program, compile(gl.VERTEX_SHADER,
    "attribute vec2 p; uniform vec2 s; varying vec2 uv; " +
    "void main() { uv = vec2(p.x, -p.y) * 0.5 + 0.5; gl_Position = vec4(p * s, 0.0, 1.0); }"));
  gl.attachShader(program, compile(gl.FRAGMENT_SHADER,
    "precision mediump float; varying vec2 uv; uniform sampler2D t; void main() { gl_FragColor = texture2D(t, uv); }"));
  gl.linkProgram(program);
  return program;
}

function xrTexture(gl, img) {
  const texture = gl.createTexture();
  gl.bindTexture(gl.TEXTURE_2D, texture);
  gl.texImage2D(gl.TEXTURE_2D, 0, gl.RGBA, gl.RGBA, gl.UNSIGNED_BYTE, img);
  for (const [k, v] of [[gl.TEXTURE_MIN_FILTER, gl.LINEAR], [gl.TEXTURE_MAG_FILTER, gl.LINEAR],
                        [gl.TEXTURE_WRAP_S, gl.CLAMP_TO_EDGE], [gl.TEXTURE_WRAP_T, gl.CLAMP_TO_EDGE]]) {
    gl.texParameteri(gl.TEXTURE_2D, k, v);
  }
  return texture;
}

async function enterVR(pair) {
  const [left, right] = await Promise.all([xrImage(pair.left), xrImage(pair.right)]);
  const gl = document.createElement("canvas").getContext("webgl", { xrCompatible: true });
  if (!gl) throw new Error("no WebGL context for the headset");
  const session = await navigator.xr.requestSession("immersive-vr");
  session.updateRenderState({ baseLayer: new XRWebGLLayer(session, gl) });
  const space = await session.requestReferenceSpace("local");
  const program = xrProgram(gl);
  const buffer = gl.createBuffer();
  gl.bindBuffer(gl.ARRAY_BUFFER, buffer);
  gl.bufferData(gl.ARRAY_BUFFER, new Float32Array([-1, -1, 1, -1, -1, 1, 1, 1]), gl.STATIC_DRAW);
  const textures = { left: xrTexture(gl, left), right: xrTexture(gl, right) };
  const aspect = left.naturalHeight / left.naturalWidth;
  session.addEventListener("select", () => session.end());
  const frame = (time, xrFrame) => {
    const pose = xrFrame.getViewerPose(space);
    const layer = session.renderState.baseLayer;
    gl.bindFramebuffer(gl.FRAMEBUFFER, layer.framebuffer);
    gl.clearColor(0, 0, 0, 1);
    gl.clear(gl.COLOR_BUFFER_BIT);
    if (pose) {
      gl.useProgram(program);
      const at = gl.getAttribLocation(program, "p");
      gl.bindBuffer(gl.ARRAY_BUFFER, buffer);
      gl.enableVertexAttribArray(at);
      gl.vertexAttribPointer(at, 2, gl.FLOAT, false, 0, 0);
      for (const view of pose.views) {
        const vp = layer.getViewport(view);
        gl.viewport(vp.x, vp.y, vp.width, vp.height);
        gl.bindTexture(gl.TEXTURE_2D, view.eye === "right" ? textures.right : textures.left);
        gl.uniform2f(gl.getUniformLocation(program, "s"), XR_SCREEN, XR_SCREEN * aspect * vp.width / vp.height);
        gl.drawArrays(gl.TRIANGLE_STRIP, 0, 4);
      }
    }
    session.requestAnimationFrame(frame);
  };
  session.requestAnimationFrame(frame);
}
