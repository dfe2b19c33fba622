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
            string[] mrtkProps = { "_Color", "_MainTex", "_DirectionalLight", "_SphericalHarmonics" };
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
