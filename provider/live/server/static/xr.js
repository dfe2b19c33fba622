// shlight WebXR example (served at /xr.html): a white sphere and a torus knot lit by the
// provider's live SH9 lighting, in an immersive-ar session where the browser has one
// (HoloLens 2 Edge, Quest Browser, Chrome on ARCore; WebXR needs https://, so serve with
// --tls-cert/--tls-key, or use localhost), else as a preview on the page.
//
// In a session the scene is lit by three.js's own XREstimatedLight, which asks the session
// for light estimation; the page installs the provider's polyfill
// (/xr-lighting-polyfill.js), so where the session has no light estimation (the page does
// not ask for the browser's own unless ?native=1) the provider answers. The preview (no
// session) sets a THREE.LightProbe from the provider's messages (client-three.js).
//
// Query parameters: probe=NAME, token=T, ws=wss://HOST:8765/ (default: this server),
// yaw=DEGREES (turn the room's lighting into the XR space: the provider's -Z direction
// appears at this yaw, counterclockwise seen from above), native=1 (the browser's own light
// estimation where it has one), three=URL (where to load three.js from, read by xr.html's
// import map; default a CDN), shadows=1 (a shadow catcher on the floor: the key light casts
// the sphere's shadow onto the camera image; client-three.js connectLightProbe's `shadows` in
// the preview, xrShadows on XREstimatedLight in a session; docs/shadows_consumers.md).
import { connectLightProbe, keyLight, otherLights, shadowCatcher, xrShadows } from "./client-three.js";
import { installLightEstimationPolyfill, yawRotation } from "./xr-lighting-polyfill.js";

const params = new URLSearchParams(location.search);
const $ = (id) => document.getElementById(id);

async function main() {
  let THREE, XREstimatedLight;
  try {
    THREE = await import("three");                 // xr.html's import map says where from
    ({ XREstimatedLight } = await import("three/addons/webxr/XREstimatedLight.js"));
  } catch (err) {
    $("note").textContent = "cannot load three.js (?three=URL of build/three.module.js to use another copy)";
    throw err;
  }
  const canvas = $("scene");
  const renderer = new THREE.WebGLRenderer({ canvas, antialias: true, alpha: true });
  renderer.setPixelRatio(window.devicePixelRatio || 1);
  renderer.toneMapping = THREE.NoToneMapping;      // shows ρE/π as measured
  renderer.xr.enabled = true;
  const scene = new THREE.Scene();
  const camera = new THREE.PerspectiveCamera(40, 1, 0.05, 50);
  camera.position.set(0, 0, 3.2);                  // preview: +X right, +Y up, seen from +Z
  const group = new THREE.Group();
  const white = new THREE.MeshLambertMaterial({ color: 0xffffff });
  const sphere = new THREE.Mesh(new THREE.SphereGeometry(1, 96, 48), white);
  const knot = new THREE.Mesh(new THREE.TorusKnotGeometry(0.28, 0.09, 160, 24), white);
  knot.position.set(1.55, 0, 0);
  knot.visible = false;                            // shown in AR, beside the sphere
  group.add(sphere, knot);
  scene.add(group);

  const provider = params.get("ws") || location.origin + "/";
  const probe = params.get("probe") || undefined;
  const token = params.get("token");
  const yaw = parseFloat(params.get("yaw") || "0") || 0;

  // Opt-in shadows: a catcher where the floor is (below the sphere in the preview; y = 0 of
  // the "local-floor" space in a session), edges about 1.3 units above it.
  const shadows = params.get("shadows") === "1";
  const floor = shadows ? shadowCatcher(THREE, { size: 6 }) : null;
  if (floor) { floor.position.y = -1.3; scene.add(floor); sphere.castShadow = knot.castShadow = true; }

  // The preview: the whole lighting (sh9 messages) in a LightProbe (with shadows: the key
  // light as a DirectionalLight, the rest in the LightProbe).
  const lightProbe = new THREE.LightProbe();
  scene.add(lightProbe);
  const conn = connectLightProbe(provider, lightProbe, {
    probe: probe || "*", token, maxHz: 60,
    rotation: yaw ? yawRotation(yaw) : null,
    shadows: floor ? { THREE, scene, renderer, catcher: floor, casterHeight: 1.3, occluder: sphere } : undefined,
    onState: (state, detail) => {
      const el = $("status");
      el.dataset.state = state;
      el.textContent = detail ? `${state} · ${detail}` : state;
    },
  });

  // In a session: XREstimatedLight, answered by the polyfill where the session has no light
  // estimation. false: no environment cube map (the provider has SH9 only).
  const polyfill = installLightEstimationPolyfill({ url: provider, probe, token, yaw });
  const xrLight = new XREstimatedLight(renderer, false);
  // At the origin, unscaled: its DirectionalLight shines from its position toward the
  // world origin (XREstimatedLight.js:112), and LightProbes ignore transforms
  // (WebGLLights.js:279-287).
  scene.add(xrLight);
  // Its primary light casts the shadows in a session; the angular radius (not in WebXR's
  // estimate) from the provider's own messages: the brightest light's, as the webxr export's
  // primary light. Asked every frame: worked out once a message.
  // The other lights, which the estimate folds into its SH, cast their shadows past the sphere.
  let radiusOf = null, radiusDeg = 0, others = [];
  const fromLatest = () => {
    if (conn.latest !== radiusOf) {
      radiusOf = conn.latest;
      const k = radiusOf && keyLight(radiusOf);
      radiusDeg = k ? k.angularRadiusDeg : 0;
      others = radiusOf ? otherLights(radiusOf, { rotation: yaw ? yawRotation(yaw) : null }) : [];
    }
  };
  const xrShadow = floor ? xrShadows(THREE, xrLight, { renderer, catcher: floor, casterHeight: 1.3, occluder: sphere,
    angularRadiusDeg: () => { fromLatest(); return radiusDeg; },
    otherLights: () => { fromLatest(); return others; },
  }) : null;
  if (xrShadow) xrShadow.active = false;
  // While it estimates, it alone lights the scene (a hidden light is not rendered:
  // WebGLRenderer.js:1875).
  const previewLight = conn.shadows ? conn.shadows.light : null;
  const estimating = (on) => {
    lightProbe.visible = !on;
    if (previewLight) previewLight.visible = !on;
    if (xrShadow) xrShadow.active = on;
  };
  xrLight.addEventListener("estimationstart", () => estimating(true));
  xrLight.addEventListener("estimationend", () => estimating(false));

  function resize() {
    if (renderer.xr.isPresenting) return;
    const w = canvas.clientWidth || 1, h = canvas.clientHeight || 1;
    renderer.setSize(w, h, false);
    camera.aspect = w / h;
    camera.updateProjectionMatrix();
  }
  window.addEventListener("resize", resize);
  resize();
  renderer.setAnimationLoop(() => renderer.render(scene, camera));

  // Immersive AR where the browser offers it.
  const button = $("enter-ar");
  if (navigator.xr && await navigator.xr.isSessionSupported("immersive-ar").catch(() => false)) {
    button.hidden = false;
    button.addEventListener("click", async () => {
      const optionalFeatures = ["local-floor", "dom-overlay"];
      if (params.get("native") === "1") optionalFeatures.push("light-estimation");
      polyfill.connect();                          // lighting on its way while the session starts
      const session = await navigator.xr.requestSession("immersive-ar", {
        optionalFeatures, domOverlay: { root: $("overlay") } });
      renderer.xr.setReferenceSpaceType("local-floor");
      await renderer.xr.setSession(session);
      group.position.set(0, 1.3, -1.2);            // in front of the user at chest height
      group.scale.setScalar(0.15);
      knot.visible = true;
      if (floor) floor.position.y = 0;             // the real floor of "local-floor"
      session.addEventListener("end", () => {
        if (floor) floor.position.y = -1.3;
        group.position.set(0, 0, 0); group.scale.setScalar(1); knot.visible = false; resize();
      });
    });
  } else {
    $("note").textContent = "no immersive-ar here: preview";
  }
  // For scripts and tests: what the page holds.
  window.shlight = { THREE, conn, lightProbe, renderer, scene, camera, sphere, yawRotation,
                     polyfill, xrLight, XREstimatedLight, floor, xrShadow };
}

main();
