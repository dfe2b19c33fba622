// shlight WebXR example (served at /xr.html): a white sphere and a torus knot lit by the
// provider's live SH9 lighting through a THREE.LightProbe, in an immersive-ar session
// where the browser has one (HoloLens 2 Edge, Quest Browser, Chrome on ARCore; WebXR
// needs https://, so serve with --tls-cert/--tls-key, or use localhost), else as a
// preview on the page.
//
// Query parameters: probe=NAME, token=T, ws=wss://HOST:8765/ (default: this server),
// yaw=DEGREES (turn the room's lighting into the XR space: the provider's -Z direction
// appears at this yaw), three=URL (where to load three.js from; default a CDN).
import { connectLightProbe } from "./client-three.js";

const THREE_VERSION = "0.187.0";
const params = new URLSearchParams(location.search);
const threeUrl = params.get("three") ||
  `https://cdn.jsdelivr.net/npm/three@${THREE_VERSION}/build/three.module.js`;
const $ = (id) => document.getElementById(id);

function yawRotation(degrees) {                     // about +Y, row-major 3×3
  const a = (degrees * Math.PI) / 180, c = Math.cos(a), s = Math.sin(a);
  return [c, 0, s, 0, 1, 0, -s, 0, c];
}

async function main() {
  let THREE;
  try {
    THREE = await import(threeUrl);
  } catch (err) {
    $("note").textContent = `cannot load three.js from ${threeUrl} (?three=URL to use another copy)`;
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

  const lightProbe = new THREE.LightProbe();
  scene.add(lightProbe);
  const yaw = parseFloat(params.get("yaw") || "0");
  const conn = connectLightProbe(params.get("ws") || location.origin + "/", lightProbe, {
    probe: params.get("probe") || "*",
    token: params.get("token"),
    maxHz: 60,
    rotation: yaw ? yawRotation(yaw) : null,
    onState: (state, detail) => {
      const el = $("status");
      el.dataset.state = state;
      el.textContent = detail ? `${state} · ${detail}` : state;
    },
  });

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
      const session = await navigator.xr.requestSession("immersive-ar", {
        optionalFeatures: ["local-floor", "dom-overlay"], domOverlay: { root: $("overlay") } });
      renderer.xr.setReferenceSpaceType("local-floor");
      await renderer.xr.setSession(session);
      group.position.set(0, 1.3, -1.2);            // in front of the user at chest height
      group.scale.setScalar(0.15);
      knot.visible = true;
      session.addEventListener("end", () => {
        group.position.set(0, 0, 0); group.scale.setScalar(1); knot.visible = false; resize();
      });
    });
  } else {
    $("note").textContent = "no immersive-ar here: preview";
  }
  // For scripts and tests: what the page holds.
  window.shlight = { THREE, conn, lightProbe, renderer, scene, camera, sphere, yawRotation };
}

main();
