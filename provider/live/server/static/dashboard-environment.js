// shlight dashboard: a glossy and a mirror sphere lit by the live reflection cube
// (shlight serve --environment; docs/contract.md §12), beside the Lambertian one.
// WebGL2: the cube's KTX2 bytes (the WebSocket's binary frame) uploaded as an RGBA16F
// cube map with all its mips, face f of level k as TEXTURE_CUBE_MAP_POSITIVE_X + f, rows
// from row 0, so that textureLod(cube, d, lod) is the radiance toward d in our frame.
// dashboard.js feeds it (window.shlightEnvironment): the cubes, the SH9 matrices and the
// exposure of the Lambertian sphere, so that the three spheres are shown alike.
"use strict";
(function () {
  const $ = (id) => document.getElementById(id);
  const GLOSSY_ROUGHNESS = 0.35, F0 = 0.04, ALBEDO = 0.8;

  const VERT = `#version 300 es
  in vec2 a_pos;
  out vec2 v_xy;
  void main() { v_xy = a_pos; gl_Position = vec4(a_pos, 0.0, 1.0); }`;

  // colour = albedo E(n)/pi + PF(R, roughness) * EnvBRDFApprox(F0, roughness, NoV)
  // (Karis's mobile analytic DFG); the mirror: PF(R, 0) alone (F = 1).
  const FRAG = `#version 300 es
  precision highp float;
  in vec2 v_xy;
  out vec4 outColor;
  uniform samplerCube u_cube;
  uniform float u_mips, u_roughness, u_mirror, u_exposure, u_albedo, u_f0;
  uniform mat4 u_M[3];
  vec2 envBRDFApprox(float roughness, float NoV) {
    const vec4 c0 = vec4(-1.0, -0.0275, -0.572, 0.022);
    const vec4 c1 = vec4(1.0, 0.0425, 1.04, -0.04);
    vec4 r = roughness * c0 + c1;
    float a004 = min(r.x * r.x, exp2(-9.28 * NoV)) * r.x + r.y;
    return vec2(-1.04, 1.04) * a004 + r.zw;
  }
  void main() {
    float r2 = dot(v_xy, v_xy);
    if (r2 > 1.0) { outColor = vec4(0.0); return; }
    vec3 N = vec3(v_xy, sqrt(1.0 - r2));
    vec3 V = vec3(0.0, 0.0, 1.0);           // seen from +Z (+X right, +Y up)
    vec3 R = reflect(-V, N);
    float NoV = max(dot(N, V), 0.0);
    vec3 colour;
    if (u_mirror > 0.5) {
      colour = textureLod(u_cube, R, 0.0).rgb;
    } else {
      vec4 n = vec4(N, 1.0);
      vec3 E = vec3(dot(n, u_M[0] * n), dot(n, u_M[1] * n), dot(n, u_M[2] * n));
      vec2 AB = envBRDFApprox(u_roughness, NoV);
      vec3 spec = textureLod(u_cube, R, u_roughness * (u_mips - 1.0)).rgb;
      colour = u_albedo * max(E, 0.0) / 3.14159265 + spec * (u_f0 * AB.x + AB.y);
    }
    vec3 t = 1.0 - exp(-u_exposure * max(colour, 0.0));
    vec3 s = mix(12.92 * t, 1.055 * pow(t, vec3(1.0 / 2.4)) - 0.055, step(0.0031308, t));
    outColor = vec4(s, 1.0);
  }`;

  const state = { gl: null, program: null, texture: null, mips: 0, seq: null,
                  matrices: null, exposure: 1, header: null, failed: "" };

  function setup() {
    const canvas = $("sphere-env");
    if (!canvas) return null;
    const gl = canvas.getContext("webgl2", { preserveDrawingBuffer: true, premultipliedAlpha: false });
    if (!gl) { state.failed = "WebGL2 is not available in this browser"; return null; }
    const shader = (type, src) => {
      const s = gl.createShader(type);
      gl.shaderSource(s, src);
      gl.compileShader(s);
      if (!gl.getShaderParameter(s, gl.COMPILE_STATUS)) throw new Error(gl.getShaderInfoLog(s));
      return s;
    };
    const p = gl.createProgram();
    gl.attachShader(p, shader(gl.VERTEX_SHADER, VERT));
    gl.attachShader(p, shader(gl.FRAGMENT_SHADER, FRAG));
    gl.linkProgram(p);
    if (!gl.getProgramParameter(p, gl.LINK_STATUS)) throw new Error(gl.getProgramInfoLog(p));
    const buf = gl.createBuffer();
    gl.bindBuffer(gl.ARRAY_BUFFER, buf);
    gl.bufferData(gl.ARRAY_BUFFER, new Float32Array([-1, -1, 1, -1, -1, 1, 1, 1]), gl.STATIC_DRAW);
    const loc = gl.getAttribLocation(p, "a_pos");
    gl.enableVertexAttribArray(loc);
    gl.vertexAttribPointer(loc, 2, gl.FLOAT, false, 0, 0);
    state.gl = gl;
    state.program = p;
    return gl;
  }

  // KTX 2.0 (the subset provider/live/reflections/ktx2.py writes): an RGBA16F cube, uncompressed.
  function parseKtx2(buffer) {
    const dv = new DataView(buffer);
    const id = [0xab, 0x4b, 0x54, 0x58, 0x20, 0x32, 0x30, 0xbb, 0x0d, 0x0a, 0x1a, 0x0a];
    for (let i = 0; i < 12; i++) if (dv.getUint8(i) !== id[i]) throw new Error("not KTX2");
    const u32 = (o) => dv.getUint32(o, true);
    const vkFormat = u32(12), size = u32(20), faces = u32(36), levels = u32(40);
    if (vkFormat !== 97 || faces !== 6 || u32(44) !== 0) throw new Error("not an RGBA16F cube");
    const mips = [];
    for (let k = 0; k < levels; k++) {
      const offset = Number(dv.getBigUint64(80 + 24 * k, true));
      const length = Number(dv.getBigUint64(88 + 24 * k, true));
      mips.push(new Uint16Array(buffer, offset, length / 2));
    }
    return { size, mips };
  }

  function upload(cube) {
    const gl = state.gl;
    if (state.texture) gl.deleteTexture(state.texture);
    const tex = gl.createTexture();
    gl.bindTexture(gl.TEXTURE_CUBE_MAP, tex);
    gl.texStorage2D(gl.TEXTURE_CUBE_MAP, cube.mips.length, gl.RGBA16F, cube.size, cube.size);
    gl.pixelStorei(gl.UNPACK_ALIGNMENT, 1);
    cube.mips.forEach((data, k) => {
      const n = cube.size >> k, face = n * n * 4;
      for (let f = 0; f < 6; f++) {
        gl.texSubImage2D(gl.TEXTURE_CUBE_MAP_POSITIVE_X + f, k, 0, 0, n, n, gl.RGBA,
                         gl.HALF_FLOAT, data.subarray(f * face, (f + 1) * face));
      }
    });
    gl.texParameteri(gl.TEXTURE_CUBE_MAP, gl.TEXTURE_MIN_FILTER, gl.LINEAR_MIPMAP_LINEAR);
    gl.texParameteri(gl.TEXTURE_CUBE_MAP, gl.TEXTURE_MAG_FILTER, gl.LINEAR);
    gl.texParameteri(gl.TEXTURE_CUBE_MAP, gl.TEXTURE_MAX_LEVEL, cube.mips.length - 1);
    state.texture = tex;
    state.mips = cube.mips.length;
  }

  function draw() {
    const gl = state.gl;
    if (!gl || !state.texture) return;
    const canvas = gl.canvas, half = canvas.width / 2;
    gl.useProgram(state.program);
    gl.clearColor(0, 0, 0, 0);
    gl.clear(gl.COLOR_BUFFER_BIT);
    const u = (name) => gl.getUniformLocation(state.program, name);
    gl.activeTexture(gl.TEXTURE0);
    gl.bindTexture(gl.TEXTURE_CUBE_MAP, state.texture);
    gl.uniform1i(u("u_cube"), 0);
    gl.uniform1f(u("u_mips"), state.mips);
    gl.uniform1f(u("u_exposure"), state.exposure);
    gl.uniform1f(u("u_albedo"), ALBEDO);
    gl.uniform1f(u("u_f0"), F0);
    gl.uniform1f(u("u_roughness"), GLOSSY_ROUGHNESS);
    // E = ñᵀMñ: the message's row-major 4×4 per channel; GLSL reads column-major, and the
    // matrices are symmetric, so either order gives the same E.
    const M = state.matrices || new Array(48).fill(0);
    gl.uniformMatrix4fv(u("u_M[0]"), false, new Float32Array(M));
    [0, 1].forEach((mirror) => {
      gl.viewport(mirror * half, 0, half, canvas.height);
      gl.uniform1f(u("u_mirror"), mirror);
      gl.drawArrays(gl.TRIANGLE_STRIP, 0, 4);
    });
    canvas.dataset.cubeSeq = String(state.seq);
  }

  function show(text) {
    const section = $("env-spheres");
    if (section) section.hidden = false;
    if ($("env-note")) $("env-note").textContent = text;
  }

  window.shlightEnvironment = {
    // An `environment` message: its cube is the next binary frame.
    announce(msg) { state.header = msg; },
    cube(buffer) {
      const msg = state.header;
      state.header = null;
      if (!msg || buffer.byteLength !== msg.byte_length) return;
      try {
        if (!state.gl && !state.failed) setup();
        if (!state.gl) { show(state.failed); return; }
        upload(parseKtx2(buffer));
        state.seq = msg.seq;
        show(`cube ${msg.size}² · ${msg.mips} mips · seq ${msg.seq} (sh9 ${msg.sh9_seq}) · ` +
             `${(msg.byte_length / 1024).toFixed(0)} KiB · ${(+msg.compute_ms).toFixed(1)} ms`);
        draw();
      } catch (err) {
        state.failed = String(err && err.message || err);
        show(`cannot show the cube: ${state.failed}`);
      }
    },
    lighting(matrices, exposure) {
      state.matrices = matrices;
      state.exposure = exposure;
      draw();
    },
    forget() {          // another probe was picked: its cube comes with its next update
      state.seq = null;
      state.header = null;
      if (state.gl && state.texture) { state.gl.deleteTexture(state.texture); state.texture = null; }
      const section = $("env-spheres");
      if (section) section.hidden = true;
    },
  };
})();
