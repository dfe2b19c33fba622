// The `unity` export of `shlight export` (provider/core/conventions/formats.py) checked in C# against
// the golden vectors ("exports" in shaders/contract_vectors.json):
//   * the Unity package's own conversion (Sh9Math: coefficients -> SphericalHarmonicsL2, and
//     matrices -> SphericalHarmonicsL2) gives the same numbers as the Python export;
//   * Unity's published ShadeSH9, written out here from UnityCG.cginc:327-372 (linear colour
//     space) on constants packed as Unity packs them (SHProperties.cs:31-44), shows what a white
//     Lambertian surface must show, and a light from +X, +Y or -Z lands on Unity's +X, +Y, +Z.
// Built with Mono's mcs by tests/clients/unity/test_export_unity.py; prints one JSON object and exits 0 if
// every check passed. Nothing here runs Unity.
using System;
using System.Collections.Generic;
using System.IO;
using System.Text;
using Shlight.Lighting;

static class ExportTest
{
    // The export's vectors have a scale of about 1: errors near 0 are measured absolutely.
    static readonly Checks checks = new Checks(1.0);

    static double[] Numbers(Dictionary<string, object> obj, string key)
    {
        return Sh9Protocol.GetNumbers(obj, key, 0, true);
    }

    // SHProperties.cs:31-44 (HDRP PackCoefficients): probe[rgb*9 + i] -> 7 float4, flattened.
    static double[] PackLikeUnity(double[] probe)
    {
        var k = new double[28];
        for (int c = 0; c < 3; c++)
        {
            int s = 9 * c;
            k[4 * c + 0] = probe[s + 3]; k[4 * c + 1] = probe[s + 1];
            k[4 * c + 2] = probe[s + 2]; k[4 * c + 3] = probe[s + 0] - probe[s + 6];
            k[12 + 4 * c + 0] = probe[s + 4]; k[12 + 4 * c + 1] = probe[s + 5];
            k[12 + 4 * c + 2] = 3.0 * probe[s + 6]; k[12 + 4 * c + 3] = probe[s + 7];
            k[24 + c] = probe[s + 8];
        }
        k[27] = 1.0;
        return k;
    }

    // UnityCG.cginc:327-372, linear colour space:
    //   SHEvalLinearL0L1: x.r = dot(unity_SHAr, float4(normal, 1)) ...
    //   SHEvalLinearL2:   vB = normal.xyzz * normal.yzzx; x2.r = dot(unity_SHBr, vB) ...
    //                     vC = normal.x*normal.x - normal.y*normal.y; x3 = unity_SHC.rgb * vC
    //   ShadeSH9 = L0L1 + L2
    static double[] ShadeSH9(double[] k, double nx, double ny, double nz)
    {
        double[] n4 = { nx, ny, nz, 1.0 };
        double[] vB = { nx * ny, ny * nz, nz * nz, nz * nx };
        double vC = nx * nx - ny * ny;
        var rgb = new double[3];
        for (int c = 0; c < 3; c++)
        {
            double x1 = 0, x2 = 0;
            for (int j = 0; j < 4; j++) { x1 += k[4 * c + j] * n4[j]; x2 += k[12 + 4 * c + j] * vB[j]; }
            rgb[c] = x1 + x2 + k[24 + c] * vC;
        }
        return rgb;
    }

    /// <summary>What a white Lambert surface shows at each Unity-frame normal (3N).</summary>
    static double[] Shown(double[] constants, double[] unityNormals, Dictionary<string, object> mainLight)
    {
        int n = unityNormals.Length / 3;
        var e = new double[3 * n];
        double[] forward = null, color = null;
        double intensity = 0;
        if (mainLight != null)
        {
            forward = Numbers(mainLight, "forward");
            color = Numbers(mainLight, "colorLinear");
            intensity = Sh9Protocol.GetNumber(mainLight, "intensity", 0);
        }
        for (int i = 0; i < n; i++)
        {
            double x = unityNormals[3 * i], y = unityNormals[3 * i + 1], z = unityNormals[3 * i + 2];
            double[] rgb = ShadeSH9(constants, x, y, z);
            // Unity's Lambert: color * intensity * saturate(dot(n, -forward)), no 1/pi in the BRDF
            double ndl = forward == null ? 0 : Math.Max(0, -(x * forward[0] + y * forward[1] + z * forward[2]));
            for (int c = 0; c < 3; c++)
                e[3 * i + c] = rgb[c] + (forward == null ? 0 : color[c] * intensity * ndl);
        }
        return e;
    }

    static void RunCase(Dictionary<string, object> cs)
    {
        string name = Sh9Protocol.GetString(cs, "name", "?");
        var unity = (Dictionary<string, object>)cs["unity"];
        double[] coeffs = Numbers(cs, "coefficients");
        double[] normals = Numbers(cs, "normals");
        double[] white = Numbers(cs, "white");
        bool lights = Sh9Protocol.GetNumber(cs, "lights", 0) > 0;
        double[] sh = Numbers(unity, "sh");
        double[] constants = Numbers(unity, "shaderConstants");

        checks.Expect("self_description", Sh9Protocol.GetString(unity, "frame", "") == "unity-lh-y-up", name + ": frame");
        checks.Expect("self_description", Sh9Protocol.GetString(unity, "quantity", "") == "irradiance_over_pi", name + ": quantity");
        checks.Expect("self_description", !Sh9Protocol.GetBool(unity, "condon_shortley", true), name + ": condon_shortley");

        // the package's conversions agree with the Python export (6-digit constants in C#)
        checks.Compare("package_from_coefficients", Sh9Math.AmbientProbeFromCoefficients(Sh9Math.CoefficientsToUnity(coeffs)), sh, 2e-6, name);
        double[] unityMatrices = Sh9Math.MatricesToUnity(Sh9Math.MatricesFromCoefficients(coeffs));
        checks.Compare("package_from_matrices", Sh9Math.AmbientProbeFromMatrices(unityMatrices), sh, 2e-6, name);
        // both sides are read from 14-significant-digit vectors (provider/verify/contract.py DIGITS)
        checks.Compare("packing", PackLikeUnity(sh), constants, 1e-13, name);
        checks.Compare("packing", Sh9Math.PackUnityShaderConstants(sh), constants, 1e-13, name + " (package)");

        int n = normals.Length / 3;
        var un = new double[3 * n];          // Unity's frame: (x, y, -z)
        for (int i = 0; i < n; i++) { un[3 * i] = normals[3 * i]; un[3 * i + 1] = normals[3 * i + 1]; un[3 * i + 2] = -normals[3 * i + 2]; }

        if (lights)
        {
            var main = (Dictionary<string, object>)unity["mainLight"];
            checks.Compare("shadesh9_white", Shown(Numbers(unity, "shaderConstantsAmbient"), un, main), white, 2e-4, name + " ambient + main light");
            checks.Compare("shadesh9_white", Shown(constants, un, null), Numbers(cs, "white_sh9"), 2e-4, name + " sh alone");
        }
        else
        {
            double[] shown = Shown(constants, un, null);
            checks.Compare("shadesh9_white", shown, white, 2e-4, name);
            object axisObj;
            if (cs.TryGetValue("light_axis", out axisObj))
            {
                double[] a = Numbers(cs, "light_axis");
                double[] ua = { a[0], a[1], -a[2] };
                int lit = 0, dark = 0;
                for (int i = 1; i < 6; i++)     // the first six normals are ±X, ±Y, ±Z
                {
                    if (shown[3 * i] > shown[3 * lit]) lit = i;
                    if (shown[3 * i] < shown[3 * dark]) dark = i;
                }
                bool litOk = Math.Abs(un[3 * lit] - ua[0]) + Math.Abs(un[3 * lit + 1] - ua[1]) + Math.Abs(un[3 * lit + 2] - ua[2]) < 1e-12;
                bool darkOk = Math.Abs(un[3 * dark] + ua[0]) + Math.Abs(un[3 * dark + 1] + ua[1]) + Math.Abs(un[3 * dark + 2] + ua[2]) < 1e-12;
                checks.Expect("one_sided_lit_side", litOk, name + ": brightest Unity normal (" + un[3 * lit] + ", " + un[3 * lit + 1] + ", " + un[3 * lit + 2] + ")");
                checks.Expect("one_sided_dark_side", darkOk && Math.Abs(shown[3 * dark]) < 2e-4, name + ": opposite side not dark");
            }
        }
    }

    static int Main(string[] args)
    {
        int cases = 0;
        try
        {
            Dictionary<string, object> doc = MiniJson.ParseObject(File.ReadAllText(args[0]));
            foreach (object o in (List<object>)doc["exports"])
            {
                RunCase((Dictionary<string, object>)o);
                cases++;
            }
        }
        catch (Exception ex)
        {
            checks.Fail("exception: " + ex);
        }
        return checks.Report(cases);
    }
}
