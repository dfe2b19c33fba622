// The light between the probes, for three.js (docs/probes.md "In the engines", docs/browsers.md).
//
//   connectProbeGrid(url, { THREE, scene, LightProbeGrid, min, max, step, token })
//     fetches the server's /probe-grid.json for the box [min, max] (metres, the world frame the
//     server's probes are placed in: right-handed, y up, as three.js's) every refreshSeconds and
//     fills a three.js LightProbeGrid with it: every lit material inside the box gets the light
//     where its fragment is (trilinear between the grid's points), no shader change.
//     LightProbeGrid: the class from 'three/addons/lighting/LightProbeGridWebGL.js' (WebGLRenderer)
//     or 'three/addons/lighting/LightProbeGrid.js' (WebGPURenderer): both hold the same atlas.
//   connectPointLight(url, object3d, { THREE, lightProbe, token })
//     subscribes to the light at the object's world position over the WebSocket and puts it into
//     a LightProbe (for scenes that light one object, or renderers without probe grids);
//     call .update() after moving the object (it re-subscribes when it moved moveThreshold).
//
// The atlas (three r187, LightProbeGridWebGL.js): one RGBA float 3D texture, nx × ny × 7 (nz + 2);
// sub-volume t (7 of them) holds 4 of a point's 27 floats (c0.rgb c1.r | c1.gb c2.rg | c2.b c3.rgb
// | c4.rgb c5.r | c5.gb c6.rg | c6.b c7.rgb | c8.rgb 0) in slices t (nz + 2) + 1 + iz, with a copy
// of the first and last slice either side (the hardware filter then never blends two sub-volumes).
// Its coefficients are radiance SH9 in the wire's order and frame (docs/contract.md §2), as the
// server sends them; its probes sit at cell centres, so the box it lights reaches half a step
// beyond the first and last points.

const PADDING = 1;
// The float offsets each sub-volume's texel starts at in a point's 27 (c0..c3, then c4..c7, then c8).
const STARTS = [0, 4, 8, 12, 16, 20, 24];

/** The /probe-grid.json address for a box and step (token in the query, as client.js sends it). */
export function gridUrl(url, { min, max, step, token } = {}) {
  const u = new URL("/probe-grid.json", url.replace(/^ws/, "http"));
  u.searchParams.set("min", min.join(","));
  u.searchParams.set("max", max.join(","));
  u.searchParams.set("step", String(step));
  if (token) u.searchParams.set("token", token);
  return u;
}

/** The grid the server computes for a box: {counts, positions, coefficients, ...}; throws
 * an Error saying the server's reason (a 400's detail, a 401, 503 while probes start). */
export async function fetchProbeGrid(url, options) {
  const r = await fetch(gridUrl(url, options), { cache: "no-store" });
  const body = await r.json().catch(() => null);
  if (!r.ok || !body || body.type !== "probe-grid") {
    throw new Error(`probe grid: HTTP ${r.status}${body && body.detail ? ": " + body.detail : ""}`);
  }
  return body;
}

/** The grid's SH9 packed as three's LightProbeGrid atlas (a Float32Array of RGBA texels);
 * into ``into`` when it has the size. */
export function packProbeGrid(grid, into = null) {
  const [nx, ny, nz] = grid.counts;
  const depth = 7 * (nz + 2 * PADDING);
  const data = into && into.length === nx * ny * depth * 4 ? into : new Float32Array(nx * ny * depth * 4);
  const c = grid.coefficients;
  for (let t = 0; t < 7; t++) {
    for (let slice = 0; slice < nz + 2 * PADDING; slice++) {
      const iz = Math.min(Math.max(slice - PADDING, 0), nz - 1);   // the padding copies the edge
      const z = t * (nz + 2 * PADDING) + slice;
      for (let iy = 0; iy < ny; iy++) {
        for (let ix = 0; ix < nx; ix++) {
          const point = ix + nx * (iy + ny * iz);
          const texel = 4 * (ix + nx * (iy + ny * z));
          for (let k = 0; k < 4; k++) {
            const f = STARTS[t] + k;
            data[texel + k] = (t === 6 && k === 3) ? 0 : c[27 * point + f];
          }
        }
      }
    }
  }
  return data;
}

/** Put a server grid into a three.js LightProbeGrid (WebGL or WebGPU): its resolution, the
 * box it lights (half a step beyond the points) and its atlas, reused while the counts hold. */
export function fillProbeGrid(THREE, probeGrid, grid) {
  const [nx, ny, nz] = grid.counts;
  const depth = 7 * (nz + 2 * PADDING);
  const old = probeGrid.texture;
  const same = old && old.image && old.image.width === nx && old.image.height === ny && old.image.depth === depth;
  const data = packProbeGrid(grid, same ? old.image.data : null);
  let texture = old;
  if (!same) {
    texture = new THREE.Data3DTexture(data, nx, ny, depth);
    texture.format = THREE.RGBAFormat;
    texture.type = THREE.FloatType;
    texture.minFilter = texture.magFilter = THREE.LinearFilter;
    texture.wrapS = texture.wrapT = texture.wrapR = THREE.ClampToEdgeWrapping;
    texture.generateMipmaps = false;
    texture.unpackAlignment = 1;
    if (old && old.dispose) old.dispose();
  }
  texture.needsUpdate = true;
  probeGrid.texture = texture;
  probeGrid.resolution.set(nx, ny, nz);
  const half = grid.step / 2;
  probeGrid.boundingBox.min.set(grid.min[0] - half, grid.min[1] - half, grid.min[2] - half);
  const n = grid.positions.length;
  probeGrid.boundingBox.max.set(grid.positions[n - 3] + half, grid.positions[n - 2] + half,
                                grid.positions[n - 1] + half);
  const size = probeGrid.boundingBox.getSize(new THREE.Vector3());
  probeGrid.width = size.x; probeGrid.height = size.y; probeGrid.depth = size.z;
  probeGrid.boundingBox.getCenter(probeGrid.position);
  return probeGrid;
}

/** Keep a LightProbeGrid in ``scene`` filled from the server's grid for [min, max] at ``step``,
 * refetched every ``refreshSeconds``. Returns {probeGrid, latest, error, ready, refresh(), close()}:
 * ``ready`` resolves with the first grid. */
export function connectProbeGrid(url, { THREE, scene, LightProbeGrid, min, max, step = 0.5, token = null,
                                        refreshSeconds = 2, onGrid = null, onError = null } = {}) {
  if (!THREE || !LightProbeGrid) throw new Error("connectProbeGrid: pass THREE and a LightProbeGrid class");
  const probeGrid = new LightProbeGrid(1, 1, 1, 1, 1, 1);
  const conn = { probeGrid, latest: null, error: null, closed: false, timer: null };
  let first;
  conn.ready = new Promise((resolve) => { first = resolve; });
  conn.refresh = async () => {
    try {
      const grid = await fetchProbeGrid(url, { min, max, step, token });
      if (conn.closed) return;
      fillProbeGrid(THREE, probeGrid, grid);
      if (!probeGrid.parent && scene) scene.add(probeGrid);
      conn.latest = grid;
      conn.error = null;
      if (onGrid) onGrid(grid);
      first(grid);
    } catch (e) {
      conn.error = String(e.message || e);
      if (onError) onError(conn.error);
    }
  };
  const loop = async () => {
    await conn.refresh();
    if (!conn.closed) conn.timer = setTimeout(loop, 1000 * refreshSeconds);
  };
  loop();
  conn.close = () => {
    conn.closed = true;
    clearTimeout(conn.timer);
    if (probeGrid.parent) probeGrid.parent.remove(probeGrid);
  };
  return conn;
}

/** Follow the light at ``object3d``'s world position: a WebSocket subscription to the point
 * (docs/contract.md, "point" messages) whose SH9 fills ``lightProbe`` (one is made and added to
 * the object's scene if not given). Returns {lightProbe, latest, update(), close()}. */
export function connectPointLight(url, object3d, { THREE, lightProbe = null, token = null,
                                                  moveThreshold = 0.25, onLight = null } = {}) {
  if (!THREE) throw new Error("connectPointLight: pass THREE");
  const probe = lightProbe || new THREE.LightProbe();
  if (!lightProbe) {
    let root = object3d;
    while (root.parent) root = root.parent;
    root.add(probe);
  }
  const target = new URL(url.replace(/^http/, "ws"));
  if (token) target.searchParams.set("token", token);
  const conn = { lightProbe: probe, latest: null, error: null, at: null };
  const ws = new WebSocket(target);
  conn.socket = ws;
  const where = () => object3d.getWorldPosition(new THREE.Vector3()).toArray();
  const subscribe = (at) => {
    conn.at = at;
    if (ws.readyState === WebSocket.OPEN) ws.send(JSON.stringify({ type: "subscribe", at }));
  };
  ws.onopen = () => subscribe(where());
  ws.onmessage = (event) => {
    const m = JSON.parse(event.data);
    if (m.type === "error") { conn.error = m.detail || m.error; return; }
    if (m.type !== "point" || !conn.at || m.position.some((v, i) => v !== conn.at[i])) return;
    const c = m.coefficients;
    for (let i = 0; i < 9; i++) probe.sh.coefficients[i].set(c[3 * i], c[3 * i + 1], c[3 * i + 2]);
    conn.latest = m;
    if (onLight) onLight(m);
  };
  conn.update = () => {
    const at = where();
    if (!conn.at || Math.hypot(at[0] - conn.at[0], at[1] - conn.at[1], at[2] - conn.at[2]) >= moveThreshold) {
      subscribe(at);
    }
  };
  conn.close = () => ws.close();
  return conn;
}
