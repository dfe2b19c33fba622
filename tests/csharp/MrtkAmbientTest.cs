// Drives SH9MrtkAmbient (the package's MonoBehaviour) through its OnEnable/OnDisable on a scene
// built with tests/unity_stubs/UnityEngineStandIn.cs -- a compile-only stand-in for UnityEngine,
// NOT Unity: shaders with the names and properties of MRTK2's Standard, MRTK3 Graphics Tools'
// Standard / Standard Canvas, Unity's Standard and shlight's SH9 Diffuse; materials with the
// spherical-harmonics toggle off, on, lit and unlit; renderers blending light probes. Prints one
// JSON object {"checks": {name: ok}, "failures": [...]} and exits 0 when every check passed.
using System;
using System.Collections.Generic;
using System.Reflection;
using System.Text;
using Shlight.Lighting;
using UnityEngine;
using UnityEngine.Rendering;

static class MrtkAmbientTest
{
    static readonly Dictionary<string, bool> checks = new Dictionary<string, bool>();
    static readonly List<string> failures = new List<string>();

    static void Expect(string name, bool ok, string detail)
    {
        bool before;
        checks[name] = (checks.TryGetValue(name, out before) ? before : true) && ok;
        if (!ok) failures.Add(name + ": " + detail);
    }

    static void Call(object target, string method)
    {
        target.GetType().GetMethod(method, BindingFlags.Instance | BindingFlags.NonPublic | BindingFlags.Public)
              .Invoke(target, null);
    }

    static Material MakeMaterial(Shader shader, string name, bool shOn, params string[] keywords)
    {
        var m = new Material(shader) { name = name };
        if (m.HasProperty("_SphericalHarmonics")) m.SetFloat("_SphericalHarmonics", shOn ? 1f : 0f);
        if (shOn) m.EnableKeyword("_SPHERICAL_HARMONICS");
        foreach (string k in keywords) m.EnableKeyword(k);
        return m;
    }

    static Renderer Hologram(string name, Transform parent, params Material[] materials)
    {
        var g = GameObject.CreatePrimitive(PrimitiveType.Sphere);
        g.name = name;
        if (parent != null) g.transform.SetParent(parent, false);
        Renderer r = g.GetComponent<Renderer>();
        r.sharedMaterials = materials;
        return r;
    }

    static bool SH(Material m) { return m.IsKeywordEnabled("_SPHERICAL_HARMONICS") && m.GetFloat("_SphericalHarmonics") == 1f; }

    static int Main()
    {
        try
        {
            // The shaders as their .shader files declare them (names: Runtime/Core/Sh9MrtkShaders.cs).
            string[] mrtkProps = { "_Color", "_MainTex", "_Metallic", "_Smoothness", "_DirectionalLight", "_SphericalHarmonics", "_Reflections" };
            Shader mrtk2 = Shader.StandInCreate("Mixed Reality Toolkit/Standard", mrtkProps);
            Shader gt = Shader.StandInCreate("Graphics Tools/Standard", mrtkProps);
            Shader gtCanvas = Shader.StandInCreate("Graphics Tools/Standard Canvas", mrtkProps);
            Shader gtNonSrp = Shader.StandInCreate("Graphics Tools/Non-SRP/StandardNonSrp", mrtkProps);
            Shader standard = Shader.StandInCreate("Standard", "_Color", "_MainTex", "_Glossiness");
            Shader sh9 = Shader.StandInCreate("Shlight/SH9 Diffuse", "_Color", "_MainTex", "_Exposure");

            Material m2Off = MakeMaterial(mrtk2, "MRTK2 off", false, "_DIRECTIONAL_LIGHT");
            Material m2OffUnlit = MakeMaterial(mrtk2, "MRTK2 off, no directional light", false);
            Material m2On = MakeMaterial(mrtk2, "MRTK2 on", true, "_DIRECTIONAL_LIGHT");
            Material gtLit = MakeMaterial(gt, "GT lit", false, "_DIRECTIONAL_LIGHT");
            Material gtUnlit = MakeMaterial(gt, "GT unlit", false);
            Material canvasDistant = MakeMaterial(gtCanvas, "GT canvas distant", false, "_DISTANT_LIGHT");
            Material nonSrp = MakeMaterial(gtNonSrp, "GT non-SRP", false, "_DIRECTIONAL_LIGHT");
            Material std = new Material(standard) { name = "Standard" };
            Material diffuse = new Material(sh9) { name = "SH9 Diffuse" };

            var root = new GameObject("Holograms");
            Renderer a = Hologram("a", root.transform, m2Off, std);
            Renderer b = Hologram("b", root.transform, m2Off, m2On);             // m2Off shared: changed once
            Renderer c = Hologram("c", a.transform, gtLit, gtUnlit);                // grandchild
            Renderer d = Hologram("d", root.transform, canvasDistant, nonSrp, m2OffUnlit, diffuse, null);
            d.lightProbeUsage = LightProbeUsage.Off;
            Renderer outside = Hologram("outside", null, MakeMaterial(mrtk2, "MRTK2 elsewhere", false));

            var helper = root.AddComponent<SH9MrtkAmbient>();
            helper.Search = SH9MrtkAmbient.Scope.ChildrenOfThisObject;
            Call(helper, "OnEnable");

            Expect("mrtk2_switched_on", SH(m2Off) && SH(m2OffUnlit), "MRTK2 materials not switched on");
            Expect("mrtk3_switched_on", SH(gtLit) && SH(gtUnlit) && SH(canvasDistant) && SH(nonSrp), "Graphics Tools materials not switched on");
            Expect("already_on_untouched", SH(m2On), "MRTK2 material that was on");
            Expect("others_untouched", !std.IsKeywordEnabled("_SPHERICAL_HARMONICS") && !diffuse.IsKeywordEnabled("_SPHERICAL_HARMONICS") &&
                   std.GetFloat("_SphericalHarmonics") == 0f, "non-MRTK materials changed");
            Expect("scope_children_only", !SH(outside.sharedMaterial), "a renderer outside the helper's object was changed");
            Expect("counts", helper.MaterialsSwitched == 6 && helper.MaterialsAlreadyOn == 1 && helper.MaterialsUnlit == 1,
                   "switched " + helper.MaterialsSwitched + ", already " + helper.MaterialsAlreadyOn + ", unlit " + helper.MaterialsUnlit);
            // MRTK3 reads the SH only when lit; MRTK2 without its directional light still shows it
            Expect("reflections_opt_in", !m2Off.IsKeywordEnabled("_REFLECTIONS") && !gtLit.IsKeywordEnabled("_REFLECTIONS") &&
                   helper.ReflectionsSwitched == 0 && !helper.LastReport.Contains("reflections"),
                   "Reflections switched on although Also Reflections is off: " + helper.LastReport);
            Expect("unlit_reported", helper.LastReport.Contains("GT unlit") && !helper.LastReport.Contains("MRTK2 off, no"),
                   helper.LastReport);
            Expect("light_probes_off", a.lightProbeUsage == LightProbeUsage.Off && b.lightProbeUsage == LightProbeUsage.Off &&
                   c.lightProbeUsage == LightProbeUsage.Off && helper.RenderersSwitched == 3,
                   "renderers still on light probes (" + helper.RenderersSwitched + " switched)");

            Call(helper, "OnDisable");
            Expect("restored", !m2Off.IsKeywordEnabled("_SPHERICAL_HARMONICS") && m2Off.GetFloat("_SphericalHarmonics") == 0f &&
                   !gtUnlit.IsKeywordEnabled("_SPHERICAL_HARMONICS") && !canvasDistant.IsKeywordEnabled("_SPHERICAL_HARMONICS") &&
                   SH(m2On) && gtLit.IsKeywordEnabled("_DIRECTIONAL_LIGHT"), "materials not put back");
            Expect("restored", a.lightProbeUsage == LightProbeUsage.BlendProbes && c.lightProbeUsage == LightProbeUsage.BlendProbes &&
                   d.lightProbeUsage == LightProbeUsage.Off, "renderers not put back");

            // whole scene, light probes left alone
            helper.Search = SH9MrtkAmbient.Scope.WholeScene;
            helper.AmbientProbeInsteadOfLightProbes = false;
            Call(helper, "OnEnable");
            Expect("scope_whole_scene", SH(outside.sharedMaterial) && SH(m2Off), "whole scene not covered");
            Expect("light_probes_kept", a.lightProbeUsage == LightProbeUsage.BlendProbes, "light probes changed although off");
            Call(helper, "OnDisable");
            Expect("restored", !SH(outside.sharedMaterial), "whole-scene materials not put back");

            // Also Reflections: the "Reflections" toggle (property _Reflections, keyword _REFLECTIONS) of every
            // MRTK material in scope; MRTK2 materials of Metallic 0 reported as faint; all put back on disable
            Material m2Metal = MakeMaterial(mrtk2, "MRTK2 metal", false, "_DIRECTIONAL_LIGHT");
            m2Metal.SetFloat("_Metallic", 1f);
            m2Metal.SetFloat("_Smoothness", 0.8f);
            Material gtReflecting = MakeMaterial(gt, "GT already reflecting", true, "_DIRECTIONAL_LIGHT", "_REFLECTIONS");
            gtReflecting.SetFloat("_Reflections", 1f);
            Hologram("e", root.transform, m2Metal, gtReflecting);
            helper.Search = SH9MrtkAmbient.Scope.ChildrenOfThisObject;
            helper.AlsoReflections = true;
            Call(helper, "OnEnable");
            Func<Material, bool> refl = m => m.IsKeywordEnabled("_REFLECTIONS") && m.GetFloat("_Reflections") == 1f;
            Expect("reflections_switched_on", refl(m2Off) && refl(m2OffUnlit) && refl(m2On) && refl(m2Metal) && refl(gtLit) &&
                   refl(gtUnlit) && refl(canvasDistant) && refl(nonSrp) && refl(gtReflecting),
                   "MRTK materials without Reflections: " + helper.LastReport);
            Expect("reflections_switched_on", SH(m2Off) && SH(gtReflecting), "spherical harmonics not on with reflections");
            Expect("reflections_others_untouched", !std.IsKeywordEnabled("_REFLECTIONS") && !diffuse.IsKeywordEnabled("_REFLECTIONS") &&
                   !refl(outside.sharedMaterial), "non-MRTK or out-of-scope material given reflections");
            Expect("reflections_counts", helper.ReflectionsSwitched == 8 && helper.ReflectionsAlreadyOn == 1 &&
                   helper.MaterialsAlreadyOn == 2 && helper.MaterialsSwitched == 7,
                   "reflections switched " + helper.ReflectionsSwitched + ", already " + helper.ReflectionsAlreadyOn +
                   "; SH switched " + helper.MaterialsSwitched + ", already " + helper.MaterialsAlreadyOn);
            // MRTK2 mixes the reflection by min(Smoothness, Metallic): Metallic 0 is faint, Graphics Tools never
            Expect("reflections_faint_reported", helper.ReflectionsFaint == 3 && helper.LastReport.Contains("MRTK2 off, no directional light") &&
                   !helper.LastReport.Contains("MRTK2 metal") && !helper.LastReport.Contains("GT lit,") &&
                   helper.LastReport.Contains("reflections switched on in 8"), helper.ReflectionsFaint + ": " + helper.LastReport);
            Call(helper, "OnDisable");
            Expect("reflections_restored", !m2Off.IsKeywordEnabled("_REFLECTIONS") && m2Off.GetFloat("_Reflections") == 0f &&
                   !m2Metal.IsKeywordEnabled("_REFLECTIONS") && !gtUnlit.IsKeywordEnabled("_REFLECTIONS") &&
                   refl(gtReflecting) && SH(gtReflecting) && SH(m2On) && !m2On.IsKeywordEnabled("_REFLECTIONS") &&
                   !SH(m2Metal), "materials not put back");
            Expect("reflections_static_helper", SH9MrtkAmbient.EnableReflections(nonSrp) && refl(nonSrp) &&
                   !SH9MrtkAmbient.EnableReflections(std) && !std.IsKeywordEnabled("_REFLECTIONS") &&
                   !SH9MrtkAmbient.EnableReflections(null), "EnableReflections");
            nonSrp.DisableKeyword("_REFLECTIONS");
            nonSrp.SetFloat("_Reflections", 0f);

            // the roughness each shader reflects from a cube on Unity's mip curve: Graphics Tools reads it on
            // that curve (1 - s); MRTK2 reads lod (1 - s)*6, i.e. the ρ with ρ(1.7 - 0.7ρ) = 1 - s (glossier)
            Sh9AmbientSwitch swM2 = Sh9MrtkShaders.Find("Mixed Reality Toolkit/Standard"), swGt = Sh9MrtkShaders.Find("Graphics Tools/Standard");
            double r05 = Sh9MrtkShaders.ReflectedRoughness(swM2, 0.5);
            Expect("mrtk2_lod_curve", Math.Abs(r05 - (1.7 - Math.Sqrt(1.7 * 1.7 - 2.8 * 0.5)) / 1.4) < 1e-9 && Math.Abs(r05 - 0.3424) < 1e-3 &&
                   Sh9MrtkShaders.ReflectedRoughness(swM2, 1.0) == 0.0 && Math.Abs(Sh9MrtkShaders.ReflectedRoughness(swM2, 0.0) - 1.0) < 1e-12,
                   "MRTK2 smoothness 0.5 reflects roughness " + r05);
            Expect("mrtk2_lod_curve", Math.Abs(Sh9MrtkShaders.ReflectedRoughness(swGt, 0.3) - 0.7) < 1e-12, "Graphics Tools");
            for (int k = 0; k <= 10; k++)
            {
                double rho = k / 10.0, s = Sh9MrtkShaders.Mrtk2SmoothnessForRoughness(rho);
                // MRTK2's lod for s equals Unity's lod for rho: the same mip of the cube
                Expect("mrtk2_lod_curve", Math.Abs((1 - s) * 6 - Sh9UnityCubeBaker.UnityMipForRoughness(rho)) < 1e-9 &&
                       Math.Abs(Sh9MrtkShaders.ReflectedRoughness(swM2, s) - rho) < 1e-6, "round trip at roughness " + rho);
            }

            // the static helper for user code
            Expect("static_helper", SH9MrtkAmbient.EnableSphericalHarmonics(gtUnlit) && SH(gtUnlit), "MRTK3 material");
            Expect("static_helper", !SH9MrtkAmbient.EnableSphericalHarmonics(std) && !std.IsKeywordEnabled("_SPHERICAL_HARMONICS"),
                   "a Standard material was changed");
            Expect("static_helper", !SH9MrtkAmbient.EnableSphericalHarmonics(null), "null");
        }
        catch (Exception e)
        {
            failures.Add("exception: " + e);
        }
        var sb = new StringBuilder("{\"checks\":{");
        bool first = true;
        foreach (KeyValuePair<string, bool> kv in checks)
        {
            if (!first) sb.Append(',');
            first = false;
            sb.Append(MiniJson.Quote(kv.Key)).Append(':').Append(kv.Value ? "true" : "false");
        }
        sb.Append("},\"failures\":[");
        for (int i = 0; i < failures.Count; i++) sb.Append(i > 0 ? "," : "").Append(MiniJson.Quote(failures[i]));
        Console.WriteLine(sb.Append("]}").ToString());
        return failures.Count == 0 ? 0 : 1;
    }
}
