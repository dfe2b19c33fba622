// Evaluate lighting with three.js's OWN code (npm "three", pinned in package.json), for
// tests/clients/three/test_export_threejs.py. Install: npm ci --prefix tests/node (scripts/test.sh does).
// stdin: JSON request; stdout: JSON answer.
//   {"mode": "sh", "sh": [27 numbers], "normals": [[x,y,z], ...]}
//     -> SphericalHarmonics3.fromArray(sh).getIrradianceAt / getAt per normal
//   {"mode": "xr", "estimate": {sphericalHarmonicsCoefficients, primaryLightDirection,
//                               primaryLightIntensity}, "normals": [...]}
//     -> drives three's XREstimatedLight with a mock XRSession/XRFrame (what the team's
//        WebXR polyfill must provide) and reports what it built, plus which members of the
//        mock objects three.js touched.
import { REVISION, SphericalHarmonics3, Vector3 } from 'three';
import { XREstimatedLight } from 'three/addons/webxr/XREstimatedLight.js';

const input = JSON.parse(await new Promise((resolve) => {
	let s = '';
	process.stdin.on('data', (c) => { s += c; });
	process.stdin.on('end', () => resolve(s));
}));

function evalSH(sh, normals) {
	const irradiance = [], radiance = [];
	const t = new Vector3();
	for (const n of normals) {
		const v = new Vector3(n[0], n[1], n[2]);
		sh.getIrradianceAt(v, t); irradiance.push([t.x, t.y, t.z]);
		sh.getAt(v, t); radiance.push([t.x, t.y, t.z]);
	}
	return { irradiance, radiance };
}

function logged(name, target, log) {
	return new Proxy(target, {
		get(obj, prop, recv) {
			if (typeof prop === 'string') log.add(`${name}.${prop}`);
			return Reflect.get(obj, prop, recv);
		},
		has(obj, prop) {
			if (typeof prop === 'string') log.add(`'${prop}' in ${name}`);
			return Reflect.has(obj, prop);
		},
	});
}

async function runXR(req) {
	const log = new Set();
	const listeners = {};
	let frameCallback = null;
	const probeListeners = {};
	const probe = logged('XRLightProbe', {
		probeSpace: {},
		addEventListener(type, fn) {
			log.add(`XRLightProbe.addEventListener('${type}')`);
			(probeListeners[type] ||= []).push(fn);
		},
		removeEventListener() {},
	}, log);
	const session = logged('XRSession', {
		preferredReflectionFormat: 'srgba8',
		requestLightProbe(opts) {
			log.add(`XRSession.requestLightProbe(${JSON.stringify(opts)})`);
			return Promise.resolve(probe);
		},
		requestAnimationFrame(cb) { frameCallback = cb; return 1; },
	}, log);
	if (req.environmentEstimation) {
		// Reflection path: XRWebGLBinding.getReflectionCubeMap(probe) on 'reflectionchange'.
		class XRWebGLBinding {
			constructor(sess, gl) { log.add(`new XRWebGLBinding(session === XRSession: ${sess === session})`); }
			getReflectionCubeMap(p) { log.add(`XRWebGLBinding.getReflectionCubeMap(probe: ${p === probe})`); return null; }
		}
		globalThis.XRWebGLBinding = XRWebGLBinding;
		globalThis.window = globalThis.window || { XRWebGLBinding };
	}
	const renderer = {
		getContext() { return { getExtension(n) { log.add(`gl.getExtension('${n}')`); return {}; } }; },
		properties: { get() { return {}; } },
		xr: {
			addEventListener(type, fn) { (listeners[type] ||= []).push(fn); },
			removeEventListener() {},
			getSession() { return session; },
		},
	};
	const est = req.estimate;
	const estimate = logged('XRLightEstimate', {
		sphericalHarmonicsCoefficients: new Float32Array(est.sphericalHarmonicsCoefficients),
		primaryLightDirection: est.primaryLightDirection,
		primaryLightIntensity: est.primaryLightIntensity,
	}, log);
	const frame = logged('XRFrame', {
		session,
		getLightEstimate(p) {
			log.add(`XRFrame.getLightEstimate(probe === requested probe: ${p === probe})`);
			return estimate;
		},
	}, log);

	const xrLight = new XREstimatedLight(renderer, req.environmentEstimation ?? false);
	let started = false;
	xrLight.addEventListener('estimationstart', () => { started = true; });
	for (const fn of listeners.sessionstart || []) fn();
	await new Promise((r) => setTimeout(r, 0)); // let requestLightProbe() resolve
	if (!frameCallback) throw new Error('XREstimatedLight never called session.requestAnimationFrame');
	frameCallback(0, frame);
	for (const fn of probeListeners.reflectionchange || []) fn();

	const dl = xrLight.directionalLight;
	return {
		...evalSH(xrLight.lightProbe.sh, req.normals),
		probeIntensity: xrLight.lightProbe.intensity,
		directional: {
			color: [dl.color.r, dl.color.g, dl.color.b],
			intensity: dl.intensity,
			position: [dl.position.x, dl.position.y, dl.position.z],
			target: [dl.target.position.x, dl.target.position.y, dl.target.position.z],
		},
		estimationStarted: started,
		accessed: [...log].sort(),
	};
}

let out;
if (input.mode === 'sh') {
	out = evalSH(new SphericalHarmonics3().fromArray(input.sh), input.normals);
} else if (input.mode === 'xr') {
	out = await runXR(input);
} else {
	throw new Error(`unknown mode ${input.mode}`);
}
out.revision = REVISION;
process.stdout.write(JSON.stringify(out));
