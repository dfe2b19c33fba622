// Checks the package's shadow logic (unity_package/Runtime/Core/Sh9Shadows.cs and the parsing of
// "light_angular_radius_deg" in Sh9Messages.cs; issue 30) under Mono, against cases that
// tests/clients/unity/test_unity_shadows.py writes from the Python reference (provider.core.lights.shadows).
// Prints Checks' one-line JSON report; exit 0 when every check passed.
using System;
using System.Collections.Generic;
using System.IO;
using Shlight.Lighting;

static class ShadowsTest
{
    static readonly Checks checks = new Checks(1.0);

    static double[] Numbers(Dictionary<string, object> obj, string key)
    {
        return Sh9Protocol.GetNumbers(obj, key, 0, true);
    }

    static string Message(int k, string dirs, string irr, string radii)
    {
        var zeros27 = string.Join(",", new string[27].Populate("0"));
        string m = "{\"type\":\"sh9\",\"version\":1,\"probe\":\"p\",\"seq\":1,\"time\":1e9,\"frame\":\"rh-y-up\"," +
                   "\"coefficients\":[" + zeros27 + "],\"lights\":" + k + ",\"light_directions\":[" + dirs + "]," +
                   "\"light_irradiance\":[" + irr + "],\"ambient_coefficients\":[" + zeros27 + "]";
        if (radii != null) m += ",\"light_angular_radius_deg\":" + radii;
        return m + "}";
    }

    static string[] Populate(this string[] a, string v)
    {
        for (int i = 0; i < a.Length; i++) a[i] = v;
        return a;
    }

    static void Parsing()
    {
        const string dirs = "0,1,0,1,0,0", irr = "1,1,1,3,3,3";
        Sh9Message m = Sh9Protocol.Parse(Message(2, dirs, irr, "[0.27,9.5]")).Sh9;
        checks.Expect("radius_parsed", m.HasLightAngularRadius && m.LightAngularRadiusDeg.Length == 2 &&
                      m.LightAngularRadiusDeg[0] == 0.27 && m.LightAngularRadiusDeg[1] == 9.5, "radii as sent");
        m = Sh9Protocol.Parse(Message(2, dirs, irr, null)).Sh9;
        checks.Expect("radius_absent_is_hard", !m.HasLightAngularRadius && m.LightAngularRadiusDeg.Length == 2 &&
                      m.LightAngularRadiusDeg[0] == 0 && m.LightAngularRadiusDeg[1] == 0,
                      "an older server's message: zeros (hard shadows)");
        m = Sh9Protocol.Parse(Message(2, dirs, irr, "[]")).Sh9;
        checks.Expect("radius_empty_is_absent", !m.HasLightAngularRadius && m.LightAngularRadiusDeg.Length == 2,
                      "[] means not sent");
        foreach (string bad in new[] { "[1]", "[1,2,3]", "[-1,2]", "[1,95]", "[1,\"2\"]", "3" })
        {
            string why = null;
            try { Sh9Protocol.Parse(Message(2, dirs, irr, bad)); }
            catch (FormatException e) { why = e.Message; }
            checks.Expect("radius_refused", why != null && why.Contains("light_angular_radius_deg"),
                          bad + ": " + (why ?? "accepted"));
        }
    }

    static void KeyLight()
    {
        // (r, g, b) per light: luminance 1, 3, 2.9 → the brightest is 1
        double[] irr = { 1, 1, 1, 3, 3, 3, 2.9, 2.9, 2.9 };
        checks.Expect("key_brightest", Sh9Shadows.KeyLightIndex(irr, 3, -1) == 1, "light 1 is the brightest");
        checks.Expect("key_hysteresis_keeps", Sh9Shadows.KeyLightIndex(irr, 3, 2) == 2,
                      "light 2 (within 10 % of the brightest) stays key");
        checks.Expect("key_hysteresis_switches", Sh9Shadows.KeyLightIndex(irr, 3, 0) == 1,
                      "light 0 (a third of the brightest) hands over");
        checks.Expect("key_previous_out_of_range", Sh9Shadows.KeyLightIndex(irr, 3, 7) == 1, "previous 7 of 3");
        checks.Expect("key_none", Sh9Shadows.KeyLightIndex(new double[0], 0, 0) == -1, "no lights");
        // green weighs most (Rec. 709): (0, 1, 0) beats (2, 0, 2)
        checks.Expect("key_luminance", Sh9Shadows.KeyLightIndex(new double[] { 2, 0, 2, 0, 1, 0 }, 2, -1) == 1,
                      "Rec. 709 luminance, not the sum");
        checks.Expect("soft_threshold", Sh9Shadows.ShadowType(0.27) == Sh9ShadowType.Hard &&
                      Sh9Shadows.ShadowType(0.5) == Sh9ShadowType.Soft && Sh9Shadows.ShadowType(9) == Sh9ShadowType.Soft &&
                      Sh9Shadows.ShadowType(0) == Sh9ShadowType.Hard, "hard below 0.5°, soft from 0.5°");
        checks.Compare("penumbra_width", new[] { Sh9Shadows.PenumbraWidth(9, 1.0), Sh9Shadows.PenumbraWidth(0, 1),
                                                 Sh9Shadows.PenumbraWidth(0.27, 2.0) },
                       new[] { 2 * Math.Tan(9 * Math.PI / 180), 0, 4 * Math.Tan(0.27 * Math.PI / 180) }, 1e-15, "2 h tan r");
    }

    // A snapshot drawing the key light: its direction (Unity frame) and an ambient that holds every other light.
    static void Snapshots(List<object> cases)
    {
        foreach (object o in cases)
        {
            var c = (Dictionary<string, object>)o;
            Sh9Message m = Sh9Protocol.Parse(Sh9Protocol.GetString(c, "message", "")).Sh9;
            int drawn = (int)Sh9Protocol.GetNumber(c, "drawn", 0);
            var snap = new Sh9Snapshot(m, 0, 1, drawn);
            string where = "drawn " + drawn;
            checks.Expect("snapshot_drawn", snap.DrawnLight == drawn, where);
            checks.Compare("snapshot_direction", snap.UnityLightDirection, Numbers(c, "unity_direction"), 1e-12, where);
            checks.Compare("snapshot_irradiance", snap.LightIrradiance, Numbers(c, "irradiance"), 1e-12, where);
            checks.Compare("snapshot_radius", new[] { snap.LightAngularRadiusDeg }, Numbers(c, "radius"), 1e-12, where);
            checks.Compare("snapshot_ambient", snap.UnityAmbientMatrices, Numbers(c, "unity_ambient_matrices"), 1e-9, where);
            var values = new Sh9LightingValues();
            values.Set(snap, 0, 0, 0, 1, 1.0, true);
            checks.Compare("values_radius", new[] { values.LightAngularRadiusDeg }, Numbers(c, "radius"), 1e-12, where);
            // the shader slots: the drawn light, then the others (issue 30 part B: each shadowed by the occluder)
            checks.Expect("values_light_count", values.LightCount == m.Lights, where + ": " + values.LightCount);
            checks.Compare("values_slot_directions", values.LightDirections, Numbers(c, "slot_directions"), 1e-12, where);
            checks.Compare("values_slot_irradiance", values.LightIrradiances, Numbers(c, "slot_irradiance"), 1e-12, where);
            checks.Compare("values_slot_radii", values.LightAngularRadiiDeg, Numbers(c, "slot_radii"), 1e-12, where);
            // the drawn light Unity draws is slot 0
            checks.Compare("values_drawn_is_slot_0", values.LightDirection, Numbers(c, "unity_direction"), 1e-12, where);
            checks.Compare("values_drawn_irradiance", values.LightIrradiance, Numbers(c, "irradiance"), 1e-12, where);
            values.Set(snap, 0, 0, 0, 1, 1.0, false);
            checks.Expect("values_no_light_no_slots", values.LightCount == 0 && values.LightAngularRadiiDeg[0] == 0, where);
            checks.Expect("values_no_light_no_drawn", values.LightAngularRadiusDeg == 0 && values.LightDirection[0] == 0 &&
                          values.LightDirection[1] == 0 && values.LightDirection[2] == 0 && values.LightIrradiance[0] == 0, where);
        }
    }

    static void Ratios(List<object> cases)
    {
        var rgb = new double[3];
        foreach (object o in cases)
        {
            var c = (Dictionary<string, object>)o;
            double[] n = Numbers(c, "normal");
            int k = (int)Sh9Protocol.GetNumber(c, "lights", 0);
            Sh9Shadows.ShadowRatio(Numbers(c, "ambient_matrices"), Numbers(c, "light_directions"),
                                   Numbers(c, "light_irradiance"), k, n[0], n[1], n[2], Numbers(c, "visibility"), rgb);
            checks.Compare("shadow_ratio", rgb, Numbers(c, "ratio"), 1e-12, Sh9Protocol.GetString(c, "name", "?"));
            // the occluder's ambient occlusion: a sphere (x, y, z, R) seen from the receiver at "point"
            double[] p = Numbers(c, "point"), sphere = Numbers(c, "occluder"), occluded = new double[3];
            Sh9Shadows.OccludedAmbient(Numbers(c, "ambient_matrices"), n[0], n[1], n[2], p[0], p[1], p[2], sphere, occluded);
            checks.Compare("occluded_ambient", occluded, Numbers(c, "occluded_ambient"), 1e-12,
                           Sh9Protocol.GetString(c, "name", "?"));
            Sh9Shadows.ShadowRatio(Numbers(c, "ambient_matrices"), Numbers(c, "light_directions"),
                                   Numbers(c, "light_irradiance"), k, n[0], n[1], n[2], Numbers(c, "visibility"),
                                   occluded, rgb);
            checks.Compare("occluded_ratio", rgb, Numbers(c, "occluded_ratio"), 1e-12, Sh9Protocol.GetString(c, "name", "?"));
        }
    }

    // Each light's visibility past the occluder sphere (issue 30 part B) against the Python reference.
    static void Visibility(List<object> cases)
    {
        foreach (object o in cases)
        {
            var c = (Dictionary<string, object>)o;
            double[] p = Numbers(c, "point"), d = Numbers(c, "direction");
            double v = Sh9Shadows.SphereLightVisibility(p[0], p[1], p[2], Numbers(c, "sphere"), d[0], d[1], d[2],
                                                        Sh9Protocol.GetNumber(c, "radius_deg", 0));
            checks.Compare("sphere_light_visibility", new[] { v }, Numbers(c, "visibility"), 1e-12,
                           "radius " + Sh9Protocol.GetNumber(c, "radius_deg", 0));
        }
    }

    static int Main(string[] args)
    {
        int cases = 0;
        try
        {
            Parsing();
            KeyLight();
            Dictionary<string, object> doc = MiniJson.ParseObject(File.ReadAllText(args[0]));
            var ratios = (List<object>)doc["ratios"];
            var snaps = (List<object>)doc["snapshots"];
            var visibility = (List<object>)doc["visibility"];
            Ratios(ratios);
            Snapshots(snaps);
            Visibility(visibility);
            cases = ratios.Count + snaps.Count + visibility.Count;
        }
        catch (Exception e)
        {
            checks.Fail("exception: " + e);
        }
        return checks.Report(cases);
    }
}
