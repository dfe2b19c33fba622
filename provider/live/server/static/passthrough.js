// shlight → three.js on a video see-through headset: render a hologram as the headset's
// passthrough camera renders the room (docs/passthrough.md), and send that camera's views to
// `shlight serve --passthrough` (/capture) where the browser has WebXR Raw Camera Access.
// Served at /passthrough.js; it does not import three itself (pass THREE in).
//
//   import * as THREE from "three";
//   import { passthroughToneMapping, startCameraSender } from "https://HOST:8765/passthrough.js";
//   const tm = passthroughToneMapping(THREE, renderer);      // renderer.toneMapping = Custom
//   const sender = startCameraSender("wss://HOST:8765/", { session, renderer,
//     onMessage: tm.handle });                             // answers → tone mapping
//
// The model (docs/contract.md §15): a pixel that sees radiance L (the sphere's units, the
// units of the provider's SH9) records the code z_c = g_c⁻¹(exposure · wb_c · L_c), g_c the
// camera.json's inverse response (code → sensor exposure, g(118) = 0.18). A hologram whose
// linear colour is C (three's working colour, lit by the provider's SH9 at intensity 1) is
// drawn as code g⁻¹(exposure · wb · C): its real replica's code.
//
// Linear ↔ code convention: the lookup (passthroughLut) is the contract's display lookup
// (§15; the same 256 entries as Unity's, provider/core/passthrough/display.py the reference):
// g⁻¹ sampled at 256 sensor exposures X_k spaced evenly in log2 X between g(1) and g(top) (the
// smallest and largest of the three channels), each texel code / top in [0, 1] per channel;
// between texels it is linear in log2 X, below X_0 linear in X down to code 0, above X_255 the
// top code (clipped).
// The code is what the passthrough shows: the framebuffer gets code / 255 exactly, so the
// tone mapping hands three sRGB⁻¹(code / 255) when the output is sRGB (three's default and
// the XR layer's: three then encodes it back), code / 255 when the output is linear.
//
// How it reaches three r187's shaders (read at tests/node/node_modules/three): with
// renderer.toneMapping = CustomToneMapping every tone-mapped material calls
// CustomToneMapping(color) from ShaderChunk.tonemapping_pars_fragment (WebGLProgram.js:734,
// a stub `return color;` there, replaced here); its uniforms reach every material through
// Material.prototype.onBeforeCompile (WebGLRenderer.js:2272 calls it with the material's own
// uniforms before each program is made), so a material with its own onBeforeCompile needs
// tm.patchMaterial(material). renderer.toneMappingExposure multiplies as in three's own tone
// mappings (leave it 1). material.toneMapped = false opts a material out (a UI).

/** The camera.json format this reads (provider/core/radiometry/response.py). */
export const CAMERA_FORMAT = "shlight-camera-response";
/** Texels of the lookup. */
export const LUT_SIZE = 256;

const IDENTITY3 = [1, 0, 0, 0, 1, 0, 0, 0, 1];

function srgbDecode(v) {
  return v <= 0.04045 ? v / 12.92 : Math.pow((v + 0.055) / 1.055, 2.4);
}

/** sRGB's inverse response as a camera.json object (the model before the first camera). */
export function srgbCamera() {
  const col = Array.from({ length: 256 }, (_, z) => srgbDecode(z / 255));
  return { format: CAMERA_FORMAT, version: 1, method: "srgb", bits: 8, table: { r: col, g: col, b: col } };
}

function checkCamera(camera) {
  if (!camera || camera.format !== CAMERA_FORMAT) {
    throw new TypeError(`shlight passthrough: not a camera response (format ${camera && camera.format}, expected ${CAMERA_FORMAT})`);
  }
  const n = camera.bits === 16 ? 65536 : camera.bits === 8 ? 256 : 0;
  if (!n) throw new TypeError(`shlight passthrough: camera bits must be 8 or 16, got ${camera.bits}`);
  return ["r", "g", "b"].map((c) => {
    const col = camera.table && camera.table[c];
    if (!col || col.length !== n) throw new TypeError(`shlight passthrough: camera table '${c}' must have ${n} numbers`);
    for (let i = 0; i < n; i++) {
      if (!(col[i] >= 0 && Number.isFinite(col[i])) || (i && col[i] < col[i - 1])) {
        throw new TypeError(`shlight passthrough: camera table '${c}' must be finite, non-negative and increasing (code ${i})`);
      }
    }
    return col;
  });
}

/** Continuous code of sensor exposure x in an increasing table (numpy.interp's reading:
 *  clamped to the table's ends), as provider/core/passthrough/fit.py codes_of. */
function codeOf(col, x) {
  const top = col.length - 1;
  if (!(x > col[0])) return 0;
  if (x >= col[top]) return top;
  let lo = 0, hi = top;                       // col[lo] < x <= col[hi]
  while (hi - lo > 1) {
    const mid = (lo + hi) >> 1;
    if (col[mid] < x) lo = mid; else hi = mid;
  }
  const span = col[hi] - col[lo];
  return span > 0 ? lo + (x - col[lo]) / span : hi;
}

/**
 * The lookup of a camera.json object (module comment): { data: Float32Array(4·LUT_SIZE)
 * (RGBA, A = 1), range: [log2 X_0, log2 X_last], top (the largest code) }.
 */
export function passthroughLut(camera) {
  const cols = checkCamera(camera), top = cols[0].length - 1;
  const first = Math.min(...cols.map((c) => c[1]).filter((v) => v > 0));
  const last = Math.max(...cols.map((c) => c[top]));
  if (!(first > 0) || !(last > first)) throw new TypeError("shlight passthrough: camera table has no range");
  const lo = Math.log2(first), hi = Math.log2(last), data = new Float32Array(4 * LUT_SIZE);
  for (let k = 0; k < LUT_SIZE; k++) {
    const x = Math.pow(2, lo + ((hi - lo) * k) / (LUT_SIZE - 1));
    for (let c = 0; c < 3; c++) data[4 * k + c] = codeOf(cols[c], x) / top;
    data[4 * k + 3] = 1;
  }
  return { data, range: [lo, hi], top };
}

/**
 * What the shader computes, on the CPU: the code fraction (code / top, [r, g, b] in [0, 1])
 * the lookup gives linear colour `rgb` under `gain` ([r, g, b] = exposure · wb).
 */
export function lookupCodes(lut, rgb, gain) {
  const [lo, hi] = lut.range, out = [0, 0, 0];
  for (let c = 0; c < 3; c++) {
    const x = Math.max(rgb[c] * gain[c], 0);
    const t = ((Math.log2(Math.max(x, 1e-30)) - lo) / (hi - lo)) * (LUT_SIZE - 1);
    if (t < 0) { out[c] = lut.data[c] * (x / Math.pow(2, lo)); continue; }
    const tc = Math.min(t, LUT_SIZE - 1), i0 = Math.floor(tc), i1 = Math.min(i0 + 1, LUT_SIZE - 1), f = tc - i0;
    out[c] = lut.data[4 * i0 + c] * (1 - f) + lut.data[4 * i1 + c] * f;
  }
  return out;
}

const STUB = "vec3 CustomToneMapping( vec3 color ) { return color; }";
const GLSL = /* glsl */`
uniform sampler2D shPassthroughLut;   // LUT_SIZE × 1 RGBA32F: g⁻¹ (code / top) at log2-spaced X
uniform vec3 shPassthroughGain;       // exposure · wb (r, g, b)
uniform vec2 shPassthroughRange;      // log2 X at the first and the last texel
uniform float shPassthroughSRGB;      // 1: three sRGB-encodes what this returns
float shPassthroughTexel( int i, int c ) { return texelFetch( shPassthroughLut, ivec2( i, 0 ), 0 )[ c ]; }
vec3 CustomToneMapping( vec3 color ) {
	vec3 x = max( color * toneMappingExposure * shPassthroughGain, vec3( 0.0 ) );
	float last = ${LUT_SIZE - 1}.0;
	vec3 t = ( log2( max( x, vec3( 1e-30 ) ) ) - shPassthroughRange.x ) / ( shPassthroughRange.y - shPassthroughRange.x ) * last;
	vec3 code;
	for ( int c = 0; c < 3; c ++ ) {
		if ( t[ c ] < 0.0 ) {
			code[ c ] = shPassthroughTexel( 0, c ) * x[ c ] / exp2( shPassthroughRange.x );
		} else {
			float tc = min( t[ c ], last );
			int i0 = int( floor( tc ) );
			code[ c ] = mix( shPassthroughTexel( i0, c ), shPassthroughTexel( min( i0 + 1, ${LUT_SIZE - 1} ), c ), tc - float( i0 ) );
		}
	}
	code = clamp( code, 0.0, 1.0 );
	vec3 decoded = mix( pow( code * 0.9478672986 + vec3( 0.0521327014 ), vec3( 2.4 ) ), code * 0.0773993808,
	                    vec3( lessThanEqual( code, vec3( 0.04045 ) ) ) );
	return mix( code, decoded, shPassthroughSRGB );
}
`;

const installed = new WeakMap();   // THREE's ShaderChunk → { chunk, proto, users }
const shared = new WeakMap();      // THREE's ShaderChunk → the uniforms every program holds

// One set of uniforms per copy of three, kept for good: a program three compiled once keeps the
// uniform objects it was given (WebGLRenderer.js:2247-2258 reuses it without onBeforeCompile),
// so every controller, now or later, writes into the same ones (one passthrough camera a page).
function sharedUniforms(THREE) {
  let u = shared.get(THREE.ShaderChunk);
  if (!u) {
    const texture = new THREE.DataTexture(new Float32Array(4 * LUT_SIZE), LUT_SIZE, 1, THREE.RGBAFormat, THREE.FloatType);
    texture.minFilter = texture.magFilter = THREE.NearestFilter;   // texelFetch: interpolated by hand
    texture.colorSpace = THREE.NoColorSpace;
    texture.generateMipmaps = false;
    const out = { renderer: null };
    u = { out, uniforms: {
      shPassthroughLut: { value: texture },
      shPassthroughGain: { value: new THREE.Vector3(1, 1, 1) },
      shPassthroughRange: { value: new THREE.Vector2(0, 1) },
      // read at every upload: the newest controller's renderer's output transfer
      shPassthroughSRGB: { get value() {
        const r = out.renderer;
        return !r || THREE.ColorManagement.getTransfer(r.outputColorSpace) === THREE.SRGBTransfer ? 1 : 0;
      } },
    } };
    shared.set(THREE.ShaderChunk, u);
  }
  return u;
}

/**
 * Tone-map `renderer` (a THREE.WebGLRenderer, WebGL 2) as the headset's passthrough camera
 * renders the room (module comment). Options: camera (a camera.json object; default sRGB until
 * one arrives), exposure (default 1), wbGains (default [1, 1, 1]).
 * Returns a controller:
 *   handle(msg)        feed it /capture's answers (a message object or its JSON text):
 *                      "passthrough" sets exposure and white balance (dropped views and views
 *                      without an exposure are skipped), "passthrough_camera" the curve
 *   setCamera(json), setView({exposure, wb_gains})
 *   camera, exposure, wbGains, lut (passthroughLut), texture (the THREE.DataTexture),
 *   uniforms, views (answers applied), codes(rgb) (lookupCodes under the current gain),
 *   patchMaterial(m) (a material with its own onBeforeCompile), dispose()
 * The uniforms are one set per copy of three: one passthrough camera per page.
 */
export function passthroughToneMapping(THREE, renderer, options = {}) {
  if (!THREE || !renderer) throw new TypeError("passthroughToneMapping: THREE and renderer are required");
  const { uniforms, out } = sharedUniforms(THREE);
  const texture = uniforms.shPassthroughLut.value;
  let lut = null;

  const chunks = THREE.ShaderChunk;
  let state = installed.get(chunks);
  if (!state) {
    if (!chunks.tonemapping_pars_fragment.includes(STUB)) {
      throw new Error("passthroughToneMapping: this three.js has no CustomToneMapping stub to replace (r155–r187 have)");
    }
    state = { chunk: chunks.tonemapping_pars_fragment, proto: THREE.Material.prototype.onBeforeCompile, users: new Set() };
    chunks.tonemapping_pars_fragment = state.chunk.replace(STUB, GLSL);
    const proto = state.proto;
    // the uniforms reach every material that has no onBeforeCompile of its own
    THREE.Material.prototype.onBeforeCompile = function shlightPassthrough(shader, r) {
      Object.assign(shader.uniforms, uniforms);
      return proto.call(this, shader, r);
    };
    installed.set(chunks, state);
  }
  const previous = { toneMapping: renderer.toneMapping };
  renderer.toneMapping = THREE.CustomToneMapping;
  out.renderer = renderer;

  const tm = {
    uniforms, texture, views: 0,
    camera: options.camera || null, exposure: 1, wbGains: [1, 1, 1],
    get lut() { return lut; },
    setCamera(camera) {
      lut = passthroughLut(camera);
      tm.camera = camera;
      texture.image.data.set(lut.data);
      texture.needsUpdate = true;
      uniforms.shPassthroughRange.value.set(lut.range[0], lut.range[1]);
    },
    setView({ exposure, wb_gains: wb = [1, 1, 1] }) {
      if (!(exposure > 0) || !Array.isArray(wb) || wb.length !== 3 || !wb.every((v) => v > 0)) return false;
      tm.exposure = +exposure;
      tm.wbGains = wb.map(Number);
      uniforms.shPassthroughGain.value.set(tm.exposure * tm.wbGains[0], tm.exposure * tm.wbGains[1], tm.exposure * tm.wbGains[2]);
      tm.views++;
      return true;
    },
    handle(msg) {
      const m = typeof msg === "string" ? JSON.parse(msg) : msg;
      if (!m) return false;
      if (m.type === "passthrough_camera" && m.camera) { tm.setCamera(m.camera); return true; }
      if (m.type === "passthrough" && !m.dropped) return tm.setView(m);
      return false;
    },
    codes(rgb) {
      return lookupCodes(lut, rgb, [0, 1, 2].map((c) => tm.exposure * tm.wbGains[c] * renderer.toneMappingExposure));
    },
    patchMaterial(material) {
      const own = material.onBeforeCompile;
      material.onBeforeCompile = function (shader, r) {
        Object.assign(shader.uniforms, uniforms);
        return own.call(this, shader, r);
      };
      material.needsUpdate = true;
      return material;
    },
    dispose() {
      state.users.delete(tm);
      if (renderer.toneMapping === THREE.CustomToneMapping) renderer.toneMapping = previous.toneMapping;
      if (!state.users.size) {
        chunks.tonemapping_pars_fragment = state.chunk;
        THREE.Material.prototype.onBeforeCompile = state.proto;
        installed.delete(chunks);
      }
      if (out.renderer === renderer) out.renderer = null;
    },
  };
  state.users.add(tm);
  tm.setCamera(options.camera || srgbCamera());
  tm.camera = options.camera || null;
  tm.setView({ exposure: options.exposure ?? 1, wb_gains: options.wbGains || [1, 1, 1] });
  tm.views = 0;
  return tm;
}

// ---- the sender: WebXR Raw Camera Access → /capture ----------------------------------------

/**
 * Pinhole intrinsics (pixels, rows from the top, nerfstudio's convention) of a WebXR view's
 * projection matrix (16 numbers, column-major, OpenGL) for an image of width × height
 * covering the view: a camera-space point (x, y, z), z < 0, lands at column
 * cx + fl_x·x/(−z) and row cy − fl_y·y/(−z), with fl_x = w/2·P[0], fl_y = h/2·P[5],
 * cx = w/2·(1 − P[8]), cy = h/2·(1 + P[9]) (P[8], P[9]: the off-centre terms; rows from the
 * top flip the sign of P[9]'s). `skew` = w/2·P[4] (0 for every headset's camera; not sent).
 */
export function projectionIntrinsics(P, width, height) {
  const w = +width, h = +height;
  return { fl_x: (w / 2) * P[0], fl_y: (h / 2) * P[5], cx: (w / 2) * (1 - P[8]), cy: (h / 2) * (1 + P[9]),
           w, h, skew: (w / 2) * P[4] };
}

/**
 * The view's camera-to-sphere pose, 16 numbers row-major (docs/contract.md §15's
 * transform_matrix): `matrix` the XRView's transform.matrix (column-major, camera-to-reference
 * space, OpenGL camera axes as nerfstudio's), `rotation` (row-major 3×3, the provider's frame →
 * your reference space, as connectLightProbe's and the polyfill's) taken back out: Rᵀ·M.
 */
export function viewPose(matrix, rotation = null) {
  const R = rotation || IDENTITY3, out = new Array(16).fill(0);
  const m = (r, c) => matrix[4 * c + r];                // column-major
  for (let r = 0; r < 3; r++) {
    for (let c = 0; c < 4; c++) {
      out[4 * r + c] = R[r] * m(0, c) + R[3 + r] * m(1, c) + R[6 + r] * m(2, c);   // (Rᵀ M)[r][c]
    }
  }
  out[15] = 1;
  return out;
}

/** The /capture "view" message of an XRView-like {projectionMatrix, transform.matrix} for an
 *  image of width × height (docs/passthrough.md, the live route). */
export function viewMessage(view, { width, height, rotation = null, time = 0 } = {}) {
  const k = projectionIntrinsics(view.projectionMatrix, width, height);
  return { type: "view", transform_matrix: viewPose(view.transform.matrix, rotation),
           fl_x: k.fl_x, fl_y: k.fl_y, cx: k.cx, cy: k.cy, w: k.w, h: k.h, time };
}

/** Why raw camera access cannot be used here ("" where it can); `classes` may stand in for
 *  the browser's XRWebGLBinding and XRView (a key given as undefined: the browser has none). */
export function cameraAccessMissing(session = null, classes = {}) {
  const Binding = "XRWebGLBinding" in classes ? classes.XRWebGLBinding : globalThis.XRWebGLBinding;
  const View = "XRView" in classes ? classes.XRView : globalThis.XRView;
  if (typeof Binding !== "function" || !Binding.prototype || typeof Binding.prototype.getCameraImage !== "function" ||
      (typeof View === "function" && !("camera" in View.prototype))) {
    return "this browser has no WebXR Raw Camera Access (XRView.camera, XRWebGLBinding.getCameraImage: Chrome on Android has it)";
  }
  const f = session && session.enabledFeatures;
  if (f && typeof f.includes === "function" && !f.includes("camera-access")) {
    return "the XR session was started without the 'camera-access' feature (request it in optionalFeatures)";
  }
  return "";
}

const BLIT_VS = "#version 300 es\nout vec2 uv;\nvoid main() { vec2 p = vec2(float((gl_VertexID << 1) & 2), float(gl_VertexID & 2));\n  uv = p; gl_Position = vec4(2.0 * p - 1.0, 0.0, 1.0); }";
// An area average over the output texel's footprint (taps × taps bilinear reads): the camera
// image is opaque (no mipmaps of it), and one read per texel would alias a 4:1 reduction.
const BLIT_FS = `#version 300 es
precision highp float;
in vec2 uv;
uniform sampler2D image;
uniform vec2 footprint;   // the output texel in uv
uniform int taps;
out vec4 color;
void main() {
  vec4 sum = vec4(0.0);
  for (int i = 0; i < taps; i++) for (int j = 0; j < taps; j++)
    sum += texture(image, uv + footprint * ((vec2(i, j) + 0.5) / float(taps) - 0.5));
  color = sum / float(taps * taps);
}`;

function compile(gl, vs, fs) {
  const p = gl.createProgram();
  for (const [type, src] of [[gl.VERTEX_SHADER, vs], [gl.FRAGMENT_SHADER, fs]]) {
    const s = gl.createShader(type);
    gl.shaderSource(s, src);
    gl.compileShader(s);
    gl.attachShader(p, s);
  }
  gl.linkProgram(p);
  if (!gl.getProgramParameter(p, gl.LINK_STATUS)) throw new Error("shlight passthrough: blit program: " + gl.getProgramInfoLog(p));
  return p;
}

/**
 * The pixels (RGBA, rows from the top) of a WebGL texture `texture` (the camera image,
 * rows from the bottom as GL keeps them, `source` [w, h] its size) drawn at width × height
 * (an area average: taps × taps linear reads a texel) into a framebuffer of the sender's;
 * every GL binding it touches is put back.
 */
export function readTexture(gl, texture, width, height, cache = {}, source = null) {
  const saved = { fb: gl.getParameter(gl.FRAMEBUFFER_BINDING), prog: gl.getParameter(gl.CURRENT_PROGRAM),
    vao: gl.getParameter(gl.VERTEX_ARRAY_BINDING), unit: gl.getParameter(gl.ACTIVE_TEXTURE),
    viewport: gl.getParameter(gl.VIEWPORT), blend: gl.isEnabled(gl.BLEND), depth: gl.isEnabled(gl.DEPTH_TEST),
    cull: gl.isEnabled(gl.CULL_FACE), scissor: gl.isEnabled(gl.SCISSOR_TEST), stencil: gl.isEnabled(gl.STENCIL_TEST),
    pack: gl.getParameter(gl.PACK_ALIGNMENT) };
  gl.activeTexture(gl.TEXTURE0);
  const savedTex = gl.getParameter(gl.TEXTURE_BINDING_2D);
  if (!cache.program) {
    cache.program = compile(gl, BLIT_VS, BLIT_FS);
    cache.vao = gl.createVertexArray();
  }
  if (!cache.target || cache.width !== width || cache.height !== height) {
    if (cache.target) { gl.deleteTexture(cache.target); gl.deleteFramebuffer(cache.fb); }
    cache.target = gl.createTexture();
    gl.bindTexture(gl.TEXTURE_2D, cache.target);
    gl.texImage2D(gl.TEXTURE_2D, 0, gl.RGBA8, width, height, 0, gl.RGBA, gl.UNSIGNED_BYTE, null);
    cache.fb = gl.createFramebuffer();
    gl.bindFramebuffer(gl.FRAMEBUFFER, cache.fb);
    gl.framebufferTexture2D(gl.FRAMEBUFFER, gl.COLOR_ATTACHMENT0, gl.TEXTURE_2D, cache.target, 0);
    Object.assign(cache, { width, height });
  }
  gl.bindFramebuffer(gl.FRAMEBUFFER, cache.fb);
  gl.viewport(0, 0, width, height);
  for (const cap of [gl.BLEND, gl.DEPTH_TEST, gl.CULL_FACE, gl.SCISSOR_TEST, gl.STENCIL_TEST]) gl.disable(cap);
  gl.useProgram(cache.program);
  gl.bindVertexArray(cache.vao);
  gl.bindTexture(gl.TEXTURE_2D, texture);
  gl.uniform1i(gl.getUniformLocation(cache.program, "image"), 0);
  // source: [w, h] of the texture; each output texel averages ceil(w / width)² reads (at most 8²)
  const taps = source ? Math.min(8, Math.max(1, Math.ceil(source[0] / width), Math.ceil(source[1] / height))) : 1;
  gl.uniform1i(gl.getUniformLocation(cache.program, "taps"), taps);
  gl.uniform2f(gl.getUniformLocation(cache.program, "footprint"), 1 / width, 1 / height);
  gl.drawArrays(gl.TRIANGLES, 0, 3);
  const bottomUp = new Uint8Array(width * height * 4);
  gl.pixelStorei(gl.PACK_ALIGNMENT, 1);
  gl.readPixels(0, 0, width, height, gl.RGBA, gl.UNSIGNED_BYTE, bottomUp);
  // put back what was bound
  gl.pixelStorei(gl.PACK_ALIGNMENT, saved.pack);
  gl.bindTexture(gl.TEXTURE_2D, savedTex);
  gl.activeTexture(saved.unit);
  gl.bindVertexArray(saved.vao);
  gl.useProgram(saved.prog);
  gl.bindFramebuffer(gl.FRAMEBUFFER, saved.fb);
  gl.viewport(...saved.viewport);
  for (const [cap, on] of [[gl.BLEND, saved.blend], [gl.DEPTH_TEST, saved.depth], [gl.CULL_FACE, saved.cull],
                           [gl.SCISSOR_TEST, saved.scissor], [gl.STENCIL_TEST, saved.stencil]]) if (on) gl.enable(cap);
  const rows = new Uint8ClampedArray(width * height * 4), stride = width * 4;
  for (let y = 0; y < height; y++) rows.set(bottomUp.subarray((height - 1 - y) * stride, (height - y) * stride), y * stride);
  return rows;
}

/** A JPEG (Blob) of RGBA pixels, rows from the top: OffscreenCanvas.convertToBlob, else a
 *  canvas's toBlob. */
export async function encodeJpeg(rgba, width, height, quality = 0.9) {
  const image = new ImageData(rgba, width, height);
  if (typeof OffscreenCanvas === "function") {
    const c = new OffscreenCanvas(width, height);
    c.getContext("2d").putImageData(image, 0, 0);
    return c.convertToBlob({ type: "image/jpeg", quality });
  }
  const c = document.createElement("canvas");
  c.width = width; c.height = height;
  c.getContext("2d").putImageData(image, 0, 0);
  return new Promise((resolve) => c.toBlob(resolve, "image/jpeg", quality));
}

/** The /capture address of a provider's base URL (ws[s]://HOST:PORT/...), with probe and token. */
export function captureUrl(url, { probe = null, token = null } = {}) {
  const u = new URL("/capture", url.replace(/^http/, "ws"));
  if (probe) u.searchParams.set("probe", probe);
  if (token) u.searchParams.set("token", token);
  return u.href;
}

/**
 * Send the headset camera's views to `url`'s /capture (off unless called): each XR frame of
 * `session` (at most `hz` a second, default 5, one view in flight at a time), the first view
 * with a camera (XRView.camera) is read (XRWebGLBinding.getCameraImage, drawn at `width` ×
 * `height`, default the camera's size scaled to at most 320 wide), sent as the view message
 * (viewMessage: the pose taken back to the provider's frame by `rotation`) and its JPEG.
 * Options: session, gl (or renderer: its context), referenceSpace (an XRReferenceSpace, or a
 * function returning one; default renderer.xr.getReferenceSpace()), probe, token, hz,
 * maxWidth (320), width and height (the size sent, instead), quality (JPEG, 0.9), rotation (settable: sender.rotation), onMessage(msg) (every
 * answer, parsed), onState(state, detail), loop (false: no loop of its own, call capture),
 * binding (an XRWebGLBinding), XRWebGLBinding, XRView, WebSocket.
 * Where the browser has no raw camera access it sends nothing and says why once on the console
 * (sender.available false, sender.reason). Returns the sender: available, reason, state, sent,
 * skipped (due while one was in flight), answers, rotation, socket, lastView (the last view
 * message sent), capture(frame) (one frame by hand: what its own
 * requestAnimationFrame loop calls), close().
 */
export function startCameraSender(url, options = {}) {
  const opts = { hz: 5, quality: 0.9, maxWidth: 320, ...options };
  const WS = opts.WebSocket || globalThis.WebSocket;
  const gl = opts.gl || (opts.renderer && opts.renderer.getContext());
  const sender = { available: false, reason: "", state: "idle", sent: 0, skipped: 0, answers: 0,
                   rotation: opts.rotation || null, socket: null, lastView: null, capture, close };
  sender.reason = cameraAccessMissing(opts.session, options) || (gl ? "" : "startCameraSender: a WebGL context (gl or renderer) is required");
  if (sender.reason) {
    console.warn(`shlight passthrough: no camera views sent: ${sender.reason}; the hologram keeps the last curve and exposure it was given (sRGB before any)`);
    return sender;
  }
  sender.available = true;
  const binding = opts.binding ||
    new ("XRWebGLBinding" in options ? options.XRWebGLBinding : globalThis.XRWebGLBinding)(opts.session, gl);
  const cache = {};
  let last = -Infinity, busy = false, closed = false;
  const ws = new WS(captureUrl(url, opts));
  ws.binaryType = "arraybuffer";
  sender.socket = ws;
  const setState = (s, detail = "") => { sender.state = s; if (opts.onState) opts.onState(s, detail); };
  setState("connecting");
  ws.addEventListener("open", () => setState("live"));
  ws.addEventListener("close", (e) => setState("closed", `${e.code} ${e.reason}`));
  ws.addEventListener("message", (e) => {
    if (typeof e.data !== "string") return;
    const msg = JSON.parse(e.data);
    if (msg.type === "passthrough" || msg.type === "passthrough_camera") sender.answers++;
    if (msg.type === "error") console.warn(`shlight passthrough: /capture refused a view: ${msg.error} ${msg.detail || ""}`);
    if (opts.onMessage) opts.onMessage(msg);
  });

  function referenceSpace() {
    const r = opts.referenceSpace;
    if (typeof r === "function") return r();
    return r || (opts.renderer && opts.renderer.xr.getReferenceSpace());
  }

  /** One XR frame: read and send its camera view if one is due; true if one was taken. */
  function capture(frame, now = performance.now()) {
    if (closed || ws.readyState !== 1) return false;
    if (now - last < 1000 / opts.hz) return false;                       // the rate: not due yet
    if (busy || ws.bufferedAmount > 4 << 20) { sender.skipped++; return false; }   // never queued
    const space = referenceSpace(), pose = space && frame.getViewerPose(space);
    const view = pose && [...pose.views].find((v) => v.camera);
    if (!view) return false;
    const texture = binding.getCameraImage(view.camera);
    if (!texture) return false;
    const scale = Math.min(1, opts.maxWidth / view.camera.width);
    const w = opts.width || Math.round(view.camera.width * scale), h = opts.height || Math.round(view.camera.height * scale);
    const message = viewMessage(view, { width: w, height: h, rotation: sender.rotation, time: now / 1000 });
    const pixels = readTexture(gl, texture, w, h, cache, [view.camera.width, view.camera.height]);
    if (opts.renderer) opts.renderer.resetState();     // three's cached GL state: ours was put back, say so
    last = now;
    busy = true;
    encodeJpeg(pixels, w, h, opts.quality).then(async (blob) => {
      const bytes = await blob.arrayBuffer();
      if (ws.readyState === 1) { ws.send(JSON.stringify(message)); ws.send(bytes); sender.sent++; sender.lastView = message; }
    }).catch((err) => console.warn(`shlight passthrough: a view was not sent: ${err}`))
      .finally(() => { busy = false; });
    return true;
  }

  function loop(t, frame) {
    if (closed) return;
    capture(frame);
    opts.session.requestAnimationFrame(loop);
  }
  if (opts.session && opts.loop !== false) opts.session.requestAnimationFrame(loop);
  if (opts.session) opts.session.addEventListener("end", close);

  function close() {
    closed = true;
    if (ws.readyState <= 1) ws.close();
  }
  return sender;
}
