"""What each export format is, where it was read, and how to use it: the text that
:mod:`provider.core.conventions.formats` puts into every export so that it describes itself.

Data only (no code beyond a lookup). Every citation is ``repository path:lines`` at the
revision listed in :data:`REVISIONS`; the maths that follows from them, with the same
citations, is in :mod:`provider.core.conventions.formats`.
"""
from __future__ import annotations

#: Revisions the citations refer to (read at these revisions; line numbers are theirs).
REVISIONS = {
    "three": "npm three@0.187.0 (REVISION '187'; mrdoob/three.js r187)",
    "lighting-estimation": "immersive-web/lighting-estimation d7f2f3a",
    "arcore-android-sdk": "google-ar/arcore-android-sdk e525b77 (v1.53.0)",
    "arcore-unity-sdk": "google-ar/arcore-unity-sdk 9784600 (archived)",
    "UnityCsReference": "Unity-Technologies/UnityCsReference d253e09",
    "Graphics": "Unity-Technologies/Graphics ccfc218 (HDRP)",
    "Unity built-in shaders": "TwoTailsGames/Unity-Built-in-Shaders 6a63f93 (2019.4.1)",
    "glTF": "KhronosGroup/glTF 77b44be",
    "Babylon.js": "@babylonjs/core 9.34.0, @babylonjs/loaders 9.28.0 (TypeScript of their source maps)",
    "OpenXR-Docs": "KhronosGroup/OpenXR-Docs 9b64247 (1.1.62)",
    "godot_openxr_vendors": "GodotVR/godot_openxr_vendors 4272ce5",
}

COEFFICIENT_ORDER = "L00, L1-1, L10, L11, L2-2, L2-1, L20, L21, L22"
_INTERLEAVED = ("27 numbers, coefficient-major, RGB interleaved: [L00.r, L00.g, L00.b, "
                "L1-1.r, ..., L22.b]; coefficients " + COEFFICIENT_ORDER)

#: The basis tokens used in the ``basis`` field (of the wire message and of every export).
BASES = {
    "sh9-real": "real SH of Ramamoorthi & Hanrahan (2001): Y00 = 0.282095, Y1-1 = 0.488603 y, "
                "Y10 = 0.488603 z, Y11 = 0.488603 x, Y2-2 = 1.092548 xy, Y2-1 = 1.092548 yz, "
                "Y20 = 0.315392 (3z^2 - 1), Y21 = 1.092548 xz, Y22 = 0.546274 (x^2 - y^2); "
                "with condon_shortley true, Y1-1, Y11, Y2-1 and Y21 change sign",
    "unity-sh9-premultiplied": "Unity SphericalHarmonicsL2 values: the basis constant, the "
                               "cosine-lobe factor and 1/pi already multiplied in; ShadeSH9 "
                               "evaluates them with the bare polynomials 1, y, z, x, xy, yz, "
                               "3z^2 - 1, xz, x^2 - y^2",
}

NOTES = {
    "threejs": {
        "layout": "'sh': " + _INTERLEAVED,
        "usage": "new THREE.LightProbe(new THREE.SphericalHarmonics3().fromArray(sh), 1). "
                 "With lights: either 'sh' alone, or 'sh_ambient' plus one "
                 "THREE.DirectionalLight per 'directionalLights' entry (position = the "
                 "direction toward the light, target at the origin, color, intensity)",
        "description": "three.js's SphericalHarmonics3 uses our basis and signs and expects "
                       "radiance: getIrradianceAt and the shader apply the cosine lobe, "
                       "materials divide by pi. Identity conversion; three.js's world is "
                       "right-handed, +Y up. A LightProbe's own transform is ignored by "
                       "three.js: rotate the coefficients, not the object.",
        "sources": [
            "three src/math/SphericalHarmonics3.js:84-109 (getAt: constants and signs = ours)",
            "three src/math/SphericalHarmonics3.js:119-144 (getIrradianceAt applies A_l)",
            "three src/math/SphericalHarmonics3.js:274-286 (fromArray: coefficient i at 3i)",
            "three src/renderers/shaders/ShaderChunk/lights_pars_begin.glsl.js:13-46",
            "three src/renderers/shaders/ShaderChunk/common.glsl.js:103-107 (BRDF_Lambert = 1/pi)",
            "three src/renderers/webgl/WebGLLights.js:279-287, 328-332, 575-582",
        ],
    },
    "webxr": {
        "layout": "'sphericalHarmonicsCoefficients': " + _INTERLEAVED + " (index.bs:188-190); "
                  "'primaryLightDirection' {x, y, z, w: 0}; 'primaryLightIntensity' {x, y, z, w: 1}",
        "usage": "what XRFrame.getLightEstimate(probe) returns (XRLightEstimate), as three.js "
                 "XREstimatedLight consumes it: the SH go into a LightProbe unchanged, the "
                 "primary light becomes a DirectionalLight",
        "description": "The WebXR spec fixes only the order of the 27 numbers, not their "
                       "normalisation, phase or quantity. This export follows three.js's "
                       "reading (XREstimatedLight: SphericalHarmonics3, non-Condon-Shortley "
                       "radiance), the only consumer the provider's polyfill targets. "
                       "Chrome on Android passes ARCore's numbers through unconverted, which "
                       "Google's Android sample reads as Condon-Shortley-phased, and "
                       "Babylon.js reads as Condon-Shortley-phased irradiance/pi: do not mix "
                       "this object with native browser estimates, and do not feed it to "
                       "Babylon's WebXR light estimation. The primary light (the brightest "
                       "of the lights) is removed from the SH because XREstimatedLight adds "
                       "it back as a DirectionalLight; other lights stay in the SH. Direction: "
                       "toward the light (index.bs:192); intensity: RGB irradiance on a "
                       "surface facing it (index.bs:194). Frame: XRLightProbe.probeSpace, "
                       "taken to be the provider's world frame (right-handed, +Y up); a client "
                       "whose reference space is turned against it rotates the coefficients.",
        "sources": [
            "immersive-web/lighting-estimation index.bs:179-194 (XRLightEstimate)",
            "three examples/jsm/webxr/XREstimatedLight.js:93-112",
            "chromium third_party/blink/renderer/modules/xr/xr_light_estimate.cc:13-32",
            "Babylon.js core/src/XR/features/WebXRLightEstimation.pure.ts:377-406",
        ],
    },
    "unity": {
        "layout": "'sh': 27 numbers, channel-major: index rgb*9 + i = SphericalHarmonicsL2[rgb, i] "
                  "(memory order shr0..shr8, shg0..shg8, shb0..shb8); 'shaderConstants': 28 "
                  "numbers, unity_SHAr, SHAg, SHAb, SHBr, SHBg, SHBb, SHC (4 each)",
        "usage": "var p = new SphericalHarmonicsL2(); for (rgb < 3) for (i < 9) p[rgb, i] = "
                 "sh[rgb*9 + i]; RenderSettings.ambientMode = AmbientMode.Skybox (or Custom); "
                 "RenderSettings.ambientIntensity = 1; RenderSettings.ambientProbe = p. With "
                 "lights: either 'sh' alone, or 'sh_ambient' plus a directional Light with "
                 "transform.forward = mainLight.forward, color = mainLight.colorLinear "
                 "(linear; Unity wants gamma unless GraphicsSettings.lightsUseLinearIntensity), "
                 "intensity = mainLight.intensity",
        "description": "Unity stores radiance SH already multiplied by basis constant x "
                       "cosine-lobe factor / pi, in our basis without Condon-Shortley signs "
                       "(HDRP's signed constants belong to its own Condon-Shortley canonical "
                       "form and cancel); ShadeSH9 then returns irradiance/pi, what a white "
                       "Lambert surface shows (Unity's diffuse BRDF has no 1/pi). Unity is "
                       "left-handed: ours (x, y, z) -> (x, y, -z), so L10, L2-1 and L21 change "
                       "sign. The package's C# (Sh9Math.AmbientProbeFromCoefficients) computes "
                       "the same numbers.",
        "sources": [
            "UnityCsReference Editor/Mono/GI/PostProcessing.bindings.cs:36-130",
            "UnityCsReference Runtime/Export/Math/SphericalHarmonicsL2.bindings.cs:16-20, 73-79",
            "Graphics HDRP Runtime/Lighting/SphericalHarmonics.cs:58-90, 123-142",
            "Unity built-in shaders CGIncludes/UnityCG.cginc:327-372 (ShadeSH9)",
            "arcore-unity-sdk LightEstimateApi.cs:38-43, 111-159 (same factors, z flip, 1/pi)",
        ],
    },
    "arcore": {
        "layout": "'sphericalHarmonics': " + _INTERLEAVED + " (ArLightEstimate_getEnvironmental"
                  "HdrAmbientSphericalHarmonics, arcore_c_api.h:5854-5869); "
                  "'mainLightDirection' [x, y, z]; 'mainLightIntensity' [r, g, b]; from "
                  "shlight export: 'environmentalHdrCubeMap' {size 16, format, faces, images: "
                  "6 base64 strings of little-endian RGBA halves, rows from t = 0}",
        "usage": "in place of the ARCore calls: ambient SH (main light excluded), "
                 "getEnvironmentalHdrMainLightDirection / Intensity, and "
                 "acquireEnvironmentalHdrCubeMap's six images (glTexImage2D(GL_TEXTURE_CUBE_"
                 "MAP_POSITIVE_X + i, 0, GL_RGBA16F, 16, 16, 0, GL_RGBA, GL_HALF_FLOAT, bytes))",
        "description": "ARCore documents no basis, phase or frame for its 27 numbers. Google's "
                       "maintained Android sample (and Filament, sceneview, Godot) multiply them "
                       "by Condon-Shortley-signed factors: raw ARCore = radiance SH with "
                       "Condon-Shortley phase in the right-handed, +Y-up world. Google's "
                       "archived ARCore Unity SDK reads the same numbers without the phase; the "
                       "two disagree on the four m = +-1 signs (a 180-degree turn about z). "
                       "Default: the maintained sample ('condon_shortley': true); "
                       "--no-condon-shortley gives the Unity SDK's reading. The main light is "
                       "removed from the SH (ARCore's SH is ambient); direction toward the light, "
                       "intensity = RGB irradiance on a surface facing it. With no light: "
                       "ARCore's no-estimate values ([0, 1, 0], [0, 0, 0]). The cube map IS "
                       "documented: six AIMAGE_FORMAT_RGBA_FP16 images laid out as "
                       "GL_RGBA16F, linear, in the order GL_TEXTURE_CUBE_MAP_POSITIVE_X ... "
                       "NEGATIVE_Z (arcore_c_api.h:5876-5892); Google's sample uploads them "
                       "unflipped and looks them up with the world reflection vector, at 16 "
                       "x 16: our layout unchanged (radiance, main light included, as "
                       "E(SH) + E(main light) = E(cube) in ARCore).",
        "sources": [
            "arcore-android-sdk libraries/include/arcore_c_api.h:5825-5869",
            "arcore-android-sdk samples/hello_ar_java/.../HelloArActivity.java:98-110, 799-835",
            "arcore-android-sdk samples/hello_ar_java/.../shaders/environmental_hdr.frag:117-177",
            "arcore-unity-sdk LightEstimateApi.cs:125-159 (the disagreeing reading)",
            "arcore-android-sdk libraries/include/arcore_c_api.h:5876-5892 (the cube map)",
            "arcore-android-sdk samples/hello_ar_java/.../SpecularCubemapFilter.java:236-274; "
            "HelloArActivity.java:115 (16 x 16); environmental_hdr.frag:22-26, 156-158, 214-215",
        ],
    },
    "gltf": {
        "layout": "'light': an EXT_lights_image_based light object; 'irradianceCoefficients' "
                  "9 x [r, g, b] (" + COEFFICIENT_ORDER + "); with a cube: 'specularImages' "
                  "K x 6 indices into 'images' (mip-major, faces +X -X +Y -Y +Z -Z; each a "
                  "4-channel RGBD PNG data URI, rows bottom-up as Babylon uploads them), "
                  "'specularImageSize' (mip 0's edge), 'specular_roughness' (the roughness "
                  "each mip is prefiltered at), 'document' (a glTF 2.0 asset with only the light)",
        "usage": "save 'document' as a .gltf and load it into a Babylon.js scene (it becomes "
                 "scene.environmentTexture), or put 'light' into extensions."
                 "EXT_lights_image_based.lights of your asset (its image indices offset by the "
                 "asset's image count, 'images' appended) and reference it from a scene's "
                 "extensions.EXT_lights_image_based.light. Without a cube (the live "
                 "/latest.json?to=gltf, or --no-cube) 'missing_required' lists what is absent",
        "description": "The extension gives no basis, phase or frame for the coefficients. This "
                       "export follows its main consumer, Babylon.js: irradiance SH (A_l L) in "
                       "Babylon's Condon-Shortley basis, in Babylon's environment frame, "
                       "intensity 1 (Babylon multiplies by an omitted intensity and gets NaN). "
                       "A default (left-handed) Babylon scene loads glTF through a root node "
                       "that mirrors x; a right-handed scene negates z at the lookup: the two "
                       "differ by a 180-degree turn about +Y (--babylon-handedness). "
                       "The extension also requires 'specularImages' and "
                       "'specularImageSize' (light.schema.json:63-67): shlight export makes "
                       "them from the same image (same units and rotation as the SH), in "
                       "Babylon's reading: RGBD PNGs (pow(rgb, 2.2)/alpha, 0 to 255 in the "
                       "cube's units, brighter texels clipped and counted in "
                       "'specular_clipped_texels'; intensity stays 1 because Babylon applies it "
                       "to the SH twice), faces turned into the lookup frame of the chosen "
                       "scene handedness, and mip k of K GGX-prefiltered at alpha = "
                       "size^(k/(K-1) - 1), the roughness Babylon's LOD formula reads it at "
                       "(mip 0 unfiltered). The extension's README says the mips map evenly "
                       "to roughness 0..1; Babylon, its reader, does not, and this follows "
                       "Babylon. Without a cube the export lists 'missing_required' and "
                       "'light' is not a conforming light. Lights are given as "
                       "KHR_lights_punctual directional lights (intensity in lux = irradiance "
                       "for calibrated input).",
        "sources": [
            "glTF extensions/2.0/Vendor/EXT_lights_image_based/README.md:28, 53-79, 118-127",
            "glTF extensions/2.0/Vendor/EXT_lights_image_based/schema/light.schema.json:8-67",
            "Babylon.js loaders/src/glTF/2.0/Extensions/EXT_lights_image_based.pure.ts:117-148",
            "Babylon.js core/src/Maths/sphericalPolynomial.pure.ts:45-57, 241-255, 342-350, 430-431",
            "Babylon.js loaders/src/glTF/2.0/glTFLoader.pure.ts:762-768 (root node)",
            "Babylon.js core/src/Materials/materialHelper.functions.ts:305, 353, 931",
            "glTF extensions/2.0/Vendor/EXT_lights_image_based/README.md:30-49, 53-70, 83-97",
            "Babylon.js loaders/src/glTF/2.0/Extensions/EXT_lights_image_based.pure.ts:92-148 "
            "(images, lodGenerationScale = (mips - 1)/log2(size))",
            "Babylon.js core/src/Misc/environmentTextureTools.pure.ts:610-637, 730-810, 903-927 "
            "(RGBD decode, invertY, missing levels black)",
            "Babylon.js core/src/Shaders/ShadersInclude/helperFunctions.ts:104-105 (toRGBD, fromRGBD)",
            "Babylon.js core/src/Shaders/ShadersInclude/pbrIBLFunctions.ts:5, pbrBlockReflection.ts:"
            "37-43, 92-95, pbrHelperFunctions.ts:4, 9-10 (LOD from roughness)",
            "Babylon.js core/src/Materials/Textures/Filtering/hdrFiltering.ts:127-130 "
            "(alpha of each mip)",
        ],
    },
    "openxr-android": {
        "layout": "'total' and 'ambient': XrSphericalHarmonicsANDROID {kind, coefficients[9][3]: "
                  "row = coefficient (" + COEFFICIENT_ORDER + "), column = R, G, B}; "
                  "'directionalLight': XrDirectionalLightANDROID {direction, intensity, state}",
        "usage": "in place of xrGetLightEstimateANDROID's XrSphericalHarmonicsANDROID (TOTAL or "
                 "AMBIENT kind) and XrDirectionalLightANDROID",
        "description": "Radiance SH ('environment light radiance function'), TOTAL including "
                       "the main light and AMBIENT excluding it, in the XrSpace of the query "
                       "(right-handed, +Y up). The spec cites Ramamoorthi & Hanrahan without "
                       "fixing the phase; this export follows ARCore's Condon-Shortley reading, "
                       "which Godot's OpenXR vendors plugin applies to this data "
                       "(--no-condon-shortley: the literal R&H signs). Direction toward the "
                       "light, intensity = RGB irradiance. With no light: state INVALID. "
                       "No cube map: XR_ANDROID_light_estimation (the registry's, 1.1.62) has "
                       "none; the cube-map extension XR_ANDROID_light_estimation_cubemap "
                       "(revision 1, 2025-08-06) is published by Android only, outside the "
                       "Khronos registry, and the parts read here do not state its faces' "
                       "orientation or frame, so no layout is exported for it; use the arcore "
                       "cube (ARCore's documented one) or /environment.ktx2.",
        "sources": [
            "OpenXR-Docs specification/sources/chapters/extensions/android/"
            "android_light_estimation.adoc:186-187, 261-335, 388-394",
            "OpenXR-Docs specification/registry/xr.xml:7922-7923 (TOTAL / AMBIENT)",
            "godot_openxr_vendors plugin/src/main/cpp/classes/"
            "openxr_android_light_estimation.cpp:47-59, 317, 347-352",
        ],
    },
}
