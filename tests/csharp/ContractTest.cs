// Checks the package's C# core (unity_package/Runtime/Core) against contract test vectors
// (shaders/contract_vectors.json, or a file in the same format) and against one-sided lights.
// Built with Mono's mcs by tests/clients/unity/test_unity.py; prints one JSON object and exits 0 if every
// check passed, 1 otherwise. Nothing here runs Unity: it evaluates, in C#, the formulas that
// Unity's shaders evaluate (our HLSL include, and UnityCG.cginc's ShadeSH9).
using System;
using System.Collections.Generic;
using System.Globalization;
using System.IO;
using System.Text;
using Shlight.Lighting;

static class ContractTest
{
    // ñᵀMñ uses the 6-digit constants c1..c5 of Ramamoorthi & Hanrahan (docs/contract.md §2), so it
    // differs from Σ Â_l L_lm Y_lm(n) by up to ~7e-7 of the scale: the floor for every
    // irradiance comparison. Matrix and rotation algebra is checked to 1e-12.
    const double ConstantRounding = 2e-6;

    // Scale-relative errors (absolute only where the expected vector is all zeros).
    static readonly Checks checks = new Checks(0.0);

    static double[] Numbers(Dictionary<string, object> obj, string key)
    {
        return Sh9Protocol.GetNumbers(obj, key, 0, true);
    }

    static double[] ToDouble(float[] f)
    {
        var d = new double[f.Length];
        for (int i = 0; i < f.Length; i++) d[i] = f[i];
        return d;
    }

    /// <summary>Irradiance at each normal (3N) from 48 matrix numbers: 3N values, RGB per normal.</summary>
    static double[] EvalMatrices(double[] m, double[] normals)
    {
        int n = normals.Length / 3;
        var e = new double[3 * n];
        for (int k = 0; k < n; k++)
            for (int c = 0; c < 3; c++)
                e[3 * k + c] = Sh9Math.Irradiance(m, c, normals[3 * k], normals[3 * k + 1], normals[3 * k + 2]);
        return e;
    }

    /// <summary>ShadeSH9 (UnityCG.cginc) at each normal from a SphericalHarmonicsL2 (27 values).</summary>
    static double[] EvalShadeSH9(double[] probe, double[] normals)
    {
        double[] packed = Sh9Math.PackUnityShaderConstants(probe);
        int n = normals.Length / 3;
        var e = new double[3 * n];
        for (int k = 0; k < n; k++)
        {
            double[] rgb = Sh9Math.ShadeSH9(packed, normals[3 * k], normals[3 * k + 1], normals[3 * k + 2]);
            for (int c = 0; c < 3; c++) e[3 * k + c] = rgb[c];
        }
        return e;
    }

    /// <summary>Unit quaternion (x, y, z, w) of a proper rotation matrix (Shepperd's method).</summary>
    static double[] MatrixToQuaternion(double[] r)
    {
        double tr = r[0] + r[4] + r[8];
        double x, y, z, w;
        if (tr > 0)
        {
            double s = Math.Sqrt(tr + 1.0) * 2;
            w = 0.25 * s; x = (r[7] - r[5]) / s; y = (r[2] - r[6]) / s; z = (r[3] - r[1]) / s;
        }
        else if (r[0] > r[4] && r[0] > r[8])
        {
            double s = Math.Sqrt(1.0 + r[0] - r[4] - r[8]) * 2;
            w = (r[7] - r[5]) / s; x = 0.25 * s; y = (r[1] + r[3]) / s; z = (r[2] + r[6]) / s;
        }
        else if (r[4] > r[8])
        {
            double s = Math.Sqrt(1.0 + r[4] - r[0] - r[8]) * 2;
            w = (r[2] - r[6]) / s; x = (r[1] + r[3]) / s; y = 0.25 * s; z = (r[5] + r[7]) / s;
        }
        else
        {
            double s = Math.Sqrt(1.0 + r[8] - r[0] - r[4]) * 2;
            w = (r[3] - r[1]) / s; x = (r[2] + r[6]) / s; y = (r[5] + r[7]) / s; z = 0.25 * s;
        }
        return new[] { x, y, z, w };
    }

    static double[] Divide(double[] v, double d)
    {
        var r = new double[v.Length];
        for (int i = 0; i < v.Length; i++) r[i] = v[i] / d;
        return r;
    }

    static void RunCase(Dictionary<string, object> cs)
    {
        string name = Sh9Protocol.GetString(cs, "name", "?");
        double[] coeffs = Numbers(cs, "coefficients");
        double[] mats = Numbers(cs, "matrices");
        double[] normals = Numbers(cs, "normals");
        double[] irr = Numbers(cs, "irradiance");
        double[] umats = Numbers(cs, "unity_matrices");
        double[] unormals = Numbers(cs, "unity_normals");

        // 1. the wire matrices follow from the coefficients (docs/contract.md §2)
        checks.Compare("matrices_from_coefficients", Sh9Math.MatricesFromCoefficients(coeffs), mats, 1e-12, name);
        // 2. E(n) = ñᵀMñ, right-handed
        checks.Compare("irradiance_rh", EvalMatrices(mats, normals), irr, ConstantRounding, name);
        // 3. frame conversion S M S, and E in Unity's frame at (x, y, -z)
        double[] myUnity = Sh9Math.MatricesToUnity(mats);
        checks.Compare("unity_matrices", myUnity, umats, 1e-12, name);
        checks.Compare("irradiance_unity", EvalMatrices(myUnity, unormals), irr, ConstantRounding, name);
        // 4. the message path: parse a wire message built from the case, snapshot, upload values
        string wire = "{\"type\":\"sh9\",\"version\":1,\"probe\":\"default\",\"seq\":1,\"time\":0,\"stale\":false," +
                      "\"frame\":\"rh-y-up\",\"coefficients\":" + JsonArray(coeffs) + ",\"matrices\":" + JsonArray(mats) + "}";
        Sh9Parsed parsed = Sh9Protocol.Parse(wire);
        var snap = new Sh9Snapshot(parsed.Sh9, 0, 1);
        checks.Compare("message_roundtrip_unity_matrices", snap.UnityMatrices, umats, 1e-12, name);
        var values = new Sh9LightingValues();
        values.Set(snap.UnityMatrices, null, 1.0);
        checks.Compare("upload_float32_irradiance", EvalMatrices(ToDouble(values.Matrices), unormals), irr, ConstantRounding, name);
        // 5. Unity ambient probe: ShadeSH9 on the converted SphericalHarmonicsL2 = E/π
        double[] want = Divide(irr, Math.PI);
        double[] probeFromCoeffs = Sh9Math.AmbientProbeFromCoefficients(snap.UnityCoefficients);
        double[] probeFromMats = Sh9Math.AmbientProbeFromMatrices(snap.UnityMatrices);
        checks.Compare("ambient_shadesh9_from_coefficients", EvalShadeSH9(probeFromCoeffs, unormals), want, ConstantRounding, name);
        checks.Compare("ambient_shadesh9_from_matrices", EvalShadeSH9(probeFromMats, unormals), want, ConstantRounding, name);
        checks.Compare("ambient_paths_agree", probeFromMats, probeFromCoeffs, ConstantRounding, name);
        checks.Compare("ambient_float32_upload", EvalShadeSH9(ToDouble(values.AmbientProbe), unormals), want, ConstantRounding, name);

        // 6. rotation cases: M' = R̃ M R̃ᵀ, in both frames; Unity's via a quaternion like transform.rotation
        if (cs.ContainsKey("rotation"))
        {
            double[] rot = Numbers(cs, "rotation");
            double[] rmats = Numbers(cs, "rotated_matrices");
            double[] urmats = Numbers(cs, "unity_rotated_matrices");
            checks.Compare("rotated_matrices_rh", Sh9Math.RotateMatrices(mats, rot), rmats, 1e-12, name);
            double[] ur = Sh9Math.RotationToUnity(rot);
            checks.Compare("rotated_matrices_unity", Sh9Math.RotateMatrices(umats, ur), urmats, 1e-12, name);
            double[] q = MatrixToQuaternion(ur);
            double[] fromQ = Sh9Math.QuaternionToMatrix(q[0], q[1], q[2], q[3]);
            checks.Compare("quaternion_roundtrip", fromQ, ur, 1e-12, name);
            var rv = new Sh9LightingValues();
            rv.Set(snap.UnityMatrices, fromQ, 1.0);
            checks.Compare("rotated_upload_float32", ToDouble(rv.Matrices), urmats, ConstantRounding, name);
            // E'(R n) = E(n): the rotated probe seen along the rotated normal
            int n = unormals.Length / 3;
            var rn = new double[unormals.Length];
            for (int k = 0; k < n; k++)
            {
                double[] v = Sh9Math.Rotate(ur, unormals[3 * k], unormals[3 * k + 1], unormals[3 * k + 2]);
                rn[3 * k] = v[0]; rn[3 * k + 1] = v[1]; rn[3 * k + 2] = v[2];
            }
            checks.Compare("rotated_irradiance_unity", EvalMatrices(urmats, rn), irr, ConstantRounding, name);
            checks.Compare("rotated_ambient_shadesh9", EvalShadeSH9(ToDouble(rv.AmbientProbe), rn), want, ConstantRounding, name);
        }
    }

    static string JsonArray(double[] v)
    {
        var sb = new StringBuilder("[");
        for (int i = 0; i < v.Length; i++)
        {
            if (i > 0) sb.Append(',');
            sb.Append(MiniJson.Number(v[i]));
        }
        return sb.Append(']').ToString();
    }

    // ---- one-sided lights ------------------------------------------------------------------

    /// <summary>Wire coefficients (27) of a narrow light around the right-handed direction d, plus a dim ambient.</summary>
    static double[] Spot(double dx, double dy, double dz)
    {
        double[] y = {
            0.282095, 0.488603 * dy, 0.488603 * dz, 0.488603 * dx, 1.092548 * dx * dy, 1.092548 * dy * dz,
            0.315392 * (3 * dz * dz - 1), 1.092548 * dx * dz, 0.546274 * (dx * dx - dy * dy) };
        var c = new double[27];
        for (int i = 0; i < 9; i++)
            for (int ch = 0; ch < 3; ch++) c[3 * i + ch] = y[i] * (ch + 1);   // delta light, RGB = 1, 2, 3
        for (int ch = 0; ch < 3; ch++) c[ch] += 0.05 * Math.Sqrt(4 * Math.PI); // ambient 0.05
        return c;
    }

    static double Green(double[] matrices, double x, double y, double z) { return Sh9Math.Irradiance(matrices, 1, x, y, z); }

    static double GreenSH9(double[] probe, double x, double y, double z)
    {
        return Sh9Math.ShadeSH9(Sh9Math.PackUnityShaderConstants(probe), x, y, z)[1];
    }

    /// <summary>The brightest of the six axis normals: "+x", "-x", ... .</summary>
    static string Brightest(Func<double, double, double, double> f)
    {
        string[] names = { "+x", "-x", "+y", "-y", "+z", "-z" };
        double[,] dirs = { { 1, 0, 0 }, { -1, 0, 0 }, { 0, 1, 0 }, { 0, -1, 0 }, { 0, 0, 1 }, { 0, 0, -1 } };
        int best = 0; double bestE = double.NegativeInfinity;
        for (int i = 0; i < 6; i++)
        {
            double e = f(dirs[i, 0], dirs[i, 1], dirs[i, 2]);
            if (e > bestE) { bestE = e; best = i; }
        }
        return names[best];
    }

    static void OneSided(string label, double[] wireDir, double[] quaternion, string expectWorld)
    {
        double[] coeffs = Spot(wireDir[0], wireDir[1], wireDir[2]);
        string wire = "{\"type\":\"sh9\",\"version\":1,\"probe\":\"p\",\"seq\":7,\"time\":1,\"stale\":false,\"frame\":\"rh-y-up\",\"coefficients\":"
                      + JsonArray(coeffs) + "}"; // no matrices: the client derives them
        Sh9Message msg = Sh9Protocol.Parse(wire).Sh9;
        var snap = new Sh9Snapshot(msg, 0, 1);
        double[] rot = quaternion == null ? null
            : Sh9Math.QuaternionToMatrix(quaternion[0], quaternion[1], quaternion[2], quaternion[3]);
        var v = new Sh9LightingValues();
        v.Set(snap.UnityMatrices, rot, 1.0);
        double[] m = ToDouble(v.Matrices);
        double[] probe = ToDouble(v.AmbientProbe);
        string fromMatrix = Brightest((x, y, z) => Green(m, x, y, z));
        string fromAmbient = Brightest((x, y, z) => GreenSH9(probe, x, y, z));
        checks.Expect("one_sided_light", fromMatrix == expectWorld,
               label + ": matrices brightest at " + fromMatrix + ", expected " + expectWorld);
        checks.Expect("one_sided_light", fromAmbient == expectWorld,
               label + ": ambient probe brightest at " + fromAmbient + ", expected " + expectWorld);
        // the far side is darker than the lit side by a wide margin
        double[] d = { 0, 0, 0 };
        int axis = "xyz".IndexOf(expectWorld[1]);
        d[axis] = expectWorld[0] == '+' ? 1 : -1;
        double lit = Green(m, d[0], d[1], d[2]), dark = Green(m, -d[0], -d[1], -d[2]);
        checks.Expect("one_sided_light", lit > 3 * dark, label + ": lit " + lit + " vs dark " + dark);
    }

    static void OneSidedLights()
    {
        double s = Math.Sqrt(0.5);
        // No rotation: RH +X, +Y stay; RH +Z (behind the panorama centre) is Unity -Z.
        OneSided("wire +x", new double[] { 1, 0, 0 }, null, "+x");
        OneSided("wire +y", new double[] { 0, 1, 0 }, null, "+y");
        OneSided("wire +z", new double[] { 0, 0, 1 }, null, "-z");
        OneSided("wire -z (panorama centre)", new double[] { 0, 0, -1 }, null, "+z");
        // Probe on a transform with rotation Quaternion.Euler(0, 90, 0) = (0, sin45°, 0, cos45°):
        // Unity maps local right (+x) to world back (-z) and local forward (+z) to world right (+x).
        double[] yaw90 = { 0, s, 0, s };
        OneSided("yaw 90, wire +x", new double[] { 1, 0, 0 }, yaw90, "-z");
        OneSided("yaw 90, wire -z", new double[] { 0, 0, -1 }, yaw90, "+x");
        // Quaternion.Euler(90, 0, 0) = (sin45°, 0, 0, cos45°): local up (+y) goes to world forward (+z).
        double[] pitch90 = { s, 0, 0, s };
        OneSided("pitch 90, wire +y", new double[] { 0, 1, 0 }, pitch90, "+z");
        // Identity quaternion equals no rotation.
        OneSided("identity, wire +x", new double[] { 1, 0, 0 }, new double[] { 0, 0, 0, 1 }, "+x");
        // Intensity multiplier scales linearly.
        double[] coeffs = Spot(0, 1, 0);
        var snap = new Sh9Snapshot(Sh9Protocol.Parse("{\"type\":\"sh9\",\"coefficients\":" + JsonArray(coeffs) + "}").Sh9, 0, 1);
        var a = new Sh9LightingValues(); a.Set(snap.UnityMatrices, null, 1.0);
        var b = new Sh9LightingValues(); b.Set(snap.UnityMatrices, null, 2.5);
        checks.Compare("intensity_multiplier", ToDouble(b.Matrices), Sh9Math.Scale(ToDouble(a.Matrices), 2.5), 1e-6, "2.5x");
        // Furnace: uniform radiance 1 gives E = π, ShadeSH9 = 1 (a white surface shows 1).
        var f = new Sh9LightingValues(); f.SetUniform(1, 1, 1);
        checks.Compare("furnace", f.Irradiance(0.6, 0.8, 0), new[] { Math.PI, Math.PI, Math.PI }, 1e-6, "uniform");
        checks.Compare("furnace", Sh9Math.ShadeSH9(Sh9Math.PackUnityShaderConstants(ToDouble(f.AmbientProbe)), 0, 0, 1),
                new double[] { 1, 1, 1 }, 1e-6, "uniform ShadeSH9");
    }

    // ---- lights (docs/contract.md §10): a directional light split off the SH9 ---------------------------

    /// <summary>Wire coefficients (27) of a uniform radiance per channel.</summary>
    static double[] Uniform(double r, double g, double b)
    {
        var c = new double[27];
        double k = Math.Sqrt(4 * Math.PI);   // L00 of a uniform radiance L is L·sqrt(4π)
        c[0] = r * k; c[1] = g * k; c[2] = b * k;
        return c;
    }

    /// <summary>A message with one light toward the wire direction d (irradiance e) over a uniform
    /// ambient: "coefficients" the full SH9 (ambient + the light's SH9 projection), "ambient_*" the rest.</summary>
    static string LightMessage(double[] d, double[] e, double[] ambient, bool sendAmbient)
    {
        double[] full = (double[])ambient.Clone();
        Sh9Math.AddDirectionalLight(full, d[0], d[1], d[2], e[0], e[1], e[2]);
        return "{\"type\":\"sh9\",\"version\":1,\"probe\":\"p\",\"seq\":3,\"time\":1,\"stale\":false,\"frame\":\"rh-y-up\"," +
               "\"coefficients\":" + JsonArray(full) + ",\"matrices\":" + JsonArray(Sh9Math.MatricesFromCoefficients(full)) +
               ",\"lights\":1,\"light_directions\":" + JsonArray(d) + ",\"light_irradiance\":" + JsonArray(e) +
               (sendAmbient ? ",\"ambient_coefficients\":" + JsonArray(ambient) +
                              ",\"ambient_matrices\":" + JsonArray(Sh9Math.MatricesFromCoefficients(ambient)) : "") + "}";
    }

    /// <summary>
    /// The colour Unity's shaders see for a Light of colour c (sRGB-encoded) and intensity i, as Unity's
    /// documentation of GraphicsSettings.lightsUseLinearIntensity describes it, written here
    /// independently of the package: linear intensity: c.linear × i; gamma intensity: (c × i).linear;
    /// gamma colour space: c × i, then linearised by SH9 Diffuse (UNITY_COLORSPACE_GAMMA).
    /// </summary>
    static double[] UnitySeesLinear(double[] rgbi, Sh9LightColorSpace space)
    {
        var f = new double[3];
        for (int c = 0; c < 3; c++)
        {
            double srgb = rgbi[c], i = rgbi[3];
            f[c] = space == Sh9LightColorSpace.LinearIntensity ? SrgbToLinear(srgb) * i : SrgbToLinear(srgb * i);
        }
        return f;
    }

    // IEC 61966-2-1 sRGB decoding, extended above 1 with pow 2.2 like UnityCG.cginc's GammaToLinearSpaceExact.
    static double SrgbToLinear(double v)
    {
        return v <= 0.04045 ? v / 12.92 : v < 1 ? Math.Pow((v + 0.055) / 1.055, 2.4) : Math.Pow(v, 2.2);
    }

    static double Dot(double[] a, double[] b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

    static void OneSidedDirectionalLight(string label, double[] wireDir, double[] quaternion, double[] expectWorld)
    {
        double[] e = { 3.0, 2.0, 1.0 };                      // warm light, irradiance on a facing surface
        double[] ambient = Uniform(0.05, 0.05, 0.05);
        Sh9Message msg = Sh9Protocol.Parse(LightMessage(wireDir, e, ambient, true)).Sh9;
        var snap = new Sh9Snapshot(msg, 0, 1);
        var v = new Sh9LightingValues();
        double[] q = quaternion ?? new double[] { 0, 0, 0, 1 };
        v.Set(snap, q[0], q[1], q[2], q[3], 1.0, true);
        checks.Expect("light_split", v.LightActive, label + ": light not active");
        checks.Compare("light_direction_unity", v.LightDirection, expectWorld, 1e-12, label);
        // the light's transform: forward (R·(0,0,1), the direction the light travels) = -toward
        var lq = new double[4];
        Sh9Math.LookRotation(-v.LightDirection[0], -v.LightDirection[1], -v.LightDirection[2], lq);
        double[] forward = Sh9Math.Rotate(Sh9Math.QuaternionToMatrix(lq[0], lq[1], lq[2], lq[3]), 0, 0, 1);
        checks.Compare("light_forward", forward, new[] { -expectWorld[0], -expectWorld[1], -expectWorld[2] }, 1e-12, label);
        // Unity's directional light is seen from -forward (_WorldSpaceLightPos0 / _MainLightPosition);
        // a white Lambertian surface shows colour × max(0, N·L) with no 1/π: it must equal ρE/π
        double[] toLight = { -forward[0], -forward[1], -forward[2] };
        var rgbi = new double[4];
        foreach (Sh9LightColorSpace space in new[] { Sh9LightColorSpace.LinearIntensity, Sh9LightColorSpace.GammaIntensity,
                                                     Sh9LightColorSpace.Gamma })
        {
            Sh9Math.LightColorFromLinear(v.LightIrradiance[0] / Math.PI, v.LightIrradiance[1] / Math.PI,
                                         v.LightIrradiance[2] / Math.PI, space, rgbi);
            checks.Expect("light_color_range", rgbi[0] >= 0 && rgbi[0] <= 1 && rgbi[1] >= 0 && rgbi[1] <= 1 && rgbi[2] >= 0 &&
                   rgbi[2] <= 1 && rgbi[3] > 0, label + " " + space + ": colour outside [0, 1] or no intensity");
            double[] seen = UnitySeesLinear(rgbi, space);
            foreach (double sign in new[] { 1.0, -1.0 })
            {
                double[] n = { sign * expectWorld[0], sign * expectWorld[1], sign * expectWorld[2] };
                double lambert = Math.Max(0, Dot(n, toLight));
                var shown = new double[3];
                var want = new double[3];
                for (int c = 0; c < 3; c++)
                {
                    shown[c] = seen[c] * lambert;                              // Unity's Lambert, albedo 1
                    want[c] = e[c] * Math.Max(0, sign) / Math.PI;              // ρ·E/π: all on the lit side, none behind
                }
                checks.Compare("light_radiance_" + space, shown, want, 1e-6, label + (sign > 0 ? " lit side" : " far side"));
            }
        }
        // the ambient probe and SH9 globals carry the ambient only: the light is not counted twice
        double[] probe = ToDouble(v.AmbientProbe);
        double[] flat = Sh9Math.ShadeSH9(Sh9Math.PackUnityShaderConstants(probe), expectWorld[0], expectWorld[1], expectWorld[2]);
        checks.Compare("light_ambient_only", flat, new[] { 0.05, 0.05, 0.05 }, 1e-6, label + " ShadeSH9 toward the light");
        checks.Compare("light_ambient_only", v.Irradiance(expectWorld[0], expectWorld[1], expectWorld[2]),
                new[] { 0.05 * Math.PI, 0.05 * Math.PI, 0.05 * Math.PI }, 1e-6, label + " SH9 toward the light");
        // without a light to draw, the full SH9 (light included) as before
        var full = new Sh9LightingValues();
        full.Set(snap, q[0], q[1], q[2], q[3], 1.0, false);
        checks.Expect("light_not_drawn_full_sh", !full.LightActive, label + ": light active although not drawn");
        double[] fe = full.Irradiance(expectWorld[0], expectWorld[1], expectWorld[2]);
        double[] fb = full.Irradiance(-expectWorld[0], -expectWorld[1], -expectWorld[2]);
        checks.Expect("light_not_drawn_full_sh", fe[0] > 0.5 * e[0] && fe[0] > 3 * fb[0],
               label + ": full SH9 not lit toward the light: " + fe[0] + " vs " + fb[0]);
    }

    static void Lights()
    {
        double s = Math.Sqrt(0.5);
        // In Unity's frame after the z flip: wire +X stays +X, wire +Z is Unity -Z.
        OneSidedDirectionalLight("wire +x", new double[] { 1, 0, 0 }, null, new double[] { 1, 0, 0 });
        OneSidedDirectionalLight("wire -x", new double[] { -1, 0, 0 }, null, new double[] { -1, 0, 0 });
        OneSidedDirectionalLight("wire +z", new double[] { 0, 0, 1 }, null, new double[] { 0, 0, -1 });
        OneSidedDirectionalLight("wire +y (overhead sun)", new double[] { 0, 1, 0 }, null, new double[] { 0, 1, 0 });
        OneSidedDirectionalLight("wire oblique", new double[] { 0.6, 0.0, 0.8 }, null, new double[] { 0.6, 0, -0.8 });
        // probe on a transform turned by Quaternion.Euler(0, 90, 0): local right lands on world back (-z)
        OneSidedDirectionalLight("yaw 90, wire +x", new double[] { 1, 0, 0 }, new[] { 0, s, 0, s }, new double[] { 0, 0, -1 });

        // the client's Intensity scales the light as it scales the SH9
        double[] d = { 1, 0, 0 }, e = { 3, 2, 1 };
        Sh9Message msg = Sh9Protocol.Parse(LightMessage(d, e, Uniform(0.05, 0.05, 0.05), true)).Sh9;
        var snap = new Sh9Snapshot(msg, 0, 1);
        var v = new Sh9LightingValues();
        v.Set(snap, 0, 0, 0, 1, 2.5, true);
        checks.Compare("light_intensity_multiplier", v.LightIrradiance, new[] { 7.5, 5.0, 2.5 }, 1e-12, "2.5x");

        // A message with lights but no ambient_* cannot be split: the full SH9, no light drawn.
        Sh9Message noAmbient = Sh9Protocol.Parse(LightMessage(d, e, Uniform(0.05, 0.05, 0.05), false)).Sh9;
        checks.Expect("light_without_ambient", noAmbient.Lights == 1 && !noAmbient.HasLightSplit, "HasLightSplit without ambient");
        var na = new Sh9LightingValues();
        na.Set(new Sh9Snapshot(noAmbient, 0, 1), 0, 0, 0, 1, 1.0, true);
        checks.Expect("light_without_ambient", !na.LightActive, "light drawn without an ambient SH9");

        // Two lights: the first is drawn, the second stays in the SH9 (its order-2 projection).
        double[] d2 = { 0, 1, 0 }, e2 = { 1, 1, 1 };
        double[] amb = Uniform(0.1, 0.2, 0.3);
        double[] full2 = (double[])amb.Clone();
        Sh9Math.AddDirectionalLight(full2, d[0], d[1], d[2], e[0], e[1], e[2]);
        Sh9Math.AddDirectionalLight(full2, d2[0], d2[1], d2[2], e2[0], e2[1], e2[2]);
        string two = "{\"type\":\"sh9\",\"coefficients\":" + JsonArray(full2) + ",\"lights\":2,\"light_directions\":[1,0,0,0,1,0]," +
                     "\"light_irradiance\":[3,2,1,1,1,1],\"ambient_coefficients\":" + JsonArray(amb) + "}";
        Sh9Message m2 = Sh9Protocol.Parse(two).Sh9;
        checks.Expect("two_lights_parsed", m2.Lights == 2 && m2.HasLightSplit && m2.AmbientMatrices != null, "parse");
        var v2 = new Sh9LightingValues();
        v2.Set(new Sh9Snapshot(m2, 0, 1), 0, 0, 0, 1, 1.0, true);
        double[] ambPlusSecond = (double[])amb.Clone();
        Sh9Math.AddDirectionalLight(ambPlusSecond, d2[0], d2[1], d2[2], e2[0], e2[1], e2[2]);
        checks.Compare("two_lights", ToDouble(v2.Matrices),
                Sh9Math.MatricesToUnity(Sh9Math.MatricesFromCoefficients(ambPlusSecond)), 1e-6, "ambient + second light");
        checks.Compare("two_lights_first_drawn", v2.LightIrradiance, e, 0, "first light drawn");
    }

    static void LightParserChecks()
    {
        string z27 = JsonArray(new double[27]);
        string head = "{\"type\":\"sh9\",\"coefficients\":" + z27;
        // lights off: empty arrays, ambient absent, null or empty: all accepted
        foreach (string tail in new[] { "}", ",\"lights\":0}", ",\"lights\":0,\"light_directions\":[],\"light_irradiance\":[]}",
                                       ",\"lights\":0,\"light_directions\":[],\"light_irradiance\":[],\"ambient_coefficients\":[],\"ambient_matrices\":[]}",
                                       ",\"lights\":0,\"ambient_coefficients\":null}",
                                       ",\"lights\":0,\"light_directions\":[],\"light_irradiance\":[],\"ambient_coefficients\":" + z27 + "}" })
        {
            Sh9Message m = null;
            string error = null;
            try { m = Sh9Protocol.Parse(head + tail).Sh9; }
            catch (FormatException e) { error = e.Message; }
            checks.Expect("lights_parser_accepts", m != null && m.Lights == 0 && !m.HasLightSplit && m.LightDirections.Length == 0,
                   "lights off: " + tail + " " + error);
        }
        // a light toward a non-unit direction is normalised; wire layout kept
        Sh9Message ok = Sh9Protocol.Parse(head + ",\"lights\":1,\"light_directions\":[0,1.5e-0,0],\"light_irradiance\":[1,1,1]," +
                                          "\"ambient_coefficients\":" + z27 + "}").Sh9;
        checks.Expect("lights_parser_accepts", ok.Lights == 1 && ok.LightDirections[1] == 1.0 && ok.HasLightSplit &&
               ok.AmbientMatrices != null && ok.AmbientMatrices.Length == 48, "one light, derived ambient matrices");
        // bad input: a clear message naming the field
        var bad = new Dictionary<string, string>
        {
            { ",\"lights\":1,\"light_directions\":[1,0],\"light_irradiance\":[1,1,1]}", "light_directions" },
            { ",\"lights\":1,\"light_directions\":[1,0,0],\"light_irradiance\":[]}", "light_irradiance" },
            { ",\"lights\":1}", "light_directions" },
            { ",\"lights\":-1}", "lights" },
            { ",\"lights\":1.5}", "lights" },
            { ",\"lights\":\"1\"}", "lights" },
            { ",\"lights\":1,\"light_directions\":[0,0,0],\"light_irradiance\":[1,1,1]}", "unit vector" },
            { ",\"lights\":1,\"light_directions\":[1,0,0],\"light_irradiance\":[1,-1,1]}", "negative" },
            { ",\"lights\":0,\"ambient_coefficients\":[1,2,3]}", "ambient_coefficients" },
            { ",\"lights\":0,\"ambient_matrices\":[1]}", "ambient_matrices" },
            { ",\"lights\":1,\"light_directions\":[1,0,0],\"light_irradiance\":[1,\"x\",1]}", "light_irradiance" },
        };
        foreach (KeyValuePair<string, string> kv in bad)
        {
            string error = null;
            try { Sh9Protocol.Parse(head + kv.Key); }
            catch (FormatException e) { error = e.Message; }
            checks.Expect("lights_parser_rejects", error != null && error.Contains(kv.Value),
                   "accepted or unclear: " + kv.Key + " -> " + (error ?? "accepted"));
        }
    }

    // ---- no allocation on the per-frame paths ---------------------------------------------------

    static void NoAllocation()
    {
        double[] d = { 0.6, 0, 0.8 }, e = { 3, 2, 1 };
        var snap = new Sh9Snapshot(Sh9Protocol.Parse(LightMessage(d, e, Uniform(0.05, 0.05, 0.05), true)).Sh9, 0, 1);
        var v = new Sh9LightingValues();
        var q = new double[4];
        var rgbi = new double[4];
        var r9 = new double[9];
        v.Set(snap, 0.1, 0.2, 0.3, 0.9, 1.5, true);   // warm-up (JIT)
        v.SetUniform(1, 1, 1);
        Sh9Math.LookRotation(1, 2, 3, q);
        Sh9Math.LightColorFromLinear(1, 2, 3, Sh9LightColorSpace.GammaIntensity, rgbi);
        Sh9Math.QuaternionToMatrix(0, 0, 0, 1, r9);
        long before = GC.GetAllocatedBytesForCurrentThread();
        for (int i = 0; i < 1000; i++)
        {
            v.Set(snap, 0.1, 0.2 + i * 1e-4, 0.3, 0.9, 1.5, (i & 1) == 0);
            v.SetUniform(1, 0.5, 0.25);
            Sh9Math.LookRotation(1, 2, 3 + i, q);
            Sh9Math.LightColorFromLinear(1, 2, 3, (Sh9LightColorSpace)(i % 3), rgbi);
            Sh9Math.QuaternionToMatrix(0.1, 0.2, 0.3, 0.9, r9);
        }
        long bytes = GC.GetAllocatedBytesForCurrentThread() - before;
        checks.Expect("no_allocation_per_frame", bytes == 0, "Sh9LightingValues.Set & co allocated " + bytes + " bytes in 1000 calls");
    }

    // ---- parser robustness ----------------------------------------------------------------

    static void ParserChecks()
    {
        string[] bad =
        {
            "", "{", "[1,2]", "{\"type\":\"sh9\"}", "{\"type\":\"sh9\",\"coefficients\":[1,2]}",
            "{\"type\":\"sh9\",\"version\":2,\"coefficients\":" + JsonArray(new double[27]) + "}",
            "{\"type\":\"sh9\",\"frame\":\"lh\",\"coefficients\":" + JsonArray(new double[27]) + "}",
            "{\"type\":\"sh9\",\"coefficients\":[NaN" + new string(',', 26).Replace(",", ",0") + "]}",
            "{\"type\":\"sh9\",\"coefficients\":" + JsonArray(new double[27]) + ",\"matrices\":[1]}",
            "{\"type\":\"sh9\",\"stale\":\"yes\",\"coefficients\":" + JsonArray(new double[27]) + "}",
            "{\"a\":1} x", "{\"a\":1e999}", new string('[', 100) + new string(']', 100),
        };
        foreach (string text in bad)
        {
            bool threw = false;
            try { Sh9Protocol.Parse(text); }
            catch (FormatException) { threw = true; }
            checks.Expect("parser_rejects_invalid", threw, "accepted: " + (text.Length > 60 ? text.Substring(0, 60) + "..." : text));
        }
        // A full message with statistics, unicode and escapes, unknown fields and nesting is accepted.
        string good = "{\"type\":\"sh9\",\"version\":1,\"probe\":\"r\\u00e4um \\\"1\\\"\",\"seq\":42,\"time\":1700000000.25," +
                      "\"stale\":true,\"age_s\":0.5,\"frame\":\"rh-y-up\",\"coefficients\":" + JsonArray(Spot(1, 0, 0)) +
                      ",\"matrices\":" + JsonArray(Sh9Math.MatricesFromCoefficients(Spot(1, 0, 0))) +
                      ",\"compute_ms\":1.5E-1,\"min_irradiance\":[-0.1,0,1e-3],\"window_cutoff\":0,\"future\":{\"x\":[1,[2]]},\"note\":null}";
        Sh9Parsed p = Sh9Protocol.Parse(good);
        checks.Expect("parser_accepts_valid", p.Kind == Sh9MessageKind.Sh9 && p.Sh9.Probe == "r\u00e4um \"1\"" && p.Sh9.Seq == 42
               && p.Sh9.Stale && p.Sh9.AgeSeconds == 0.5 && p.Sh9.ComputeMs == 0.15 && p.Sh9.MinIrradiance[0] == -0.1
               && p.Sh9.Time == 1700000000.25 && !p.Sh9.MatricesDerived, "full message");
        Sh9Parsed h = Sh9Protocol.Parse("{\"type\":\"hello\",\"version\":1,\"provider\":\"shlight 0.1\",\"frame\":\"rh-y-up\",\"probes\":[\"default\",\"desk\"]}");
        checks.Expect("parser_accepts_valid", h.Kind == Sh9MessageKind.Hello && h.Hello.Probes.Length == 2 && h.Hello.Probes[1] == "desk", "hello");
        Sh9Parsed e = Sh9Protocol.Parse("{\"type\":\"error\",\"error\":\"unauthorized\",\"detail\":\"bad token\"}");
        checks.Expect("parser_accepts_valid", e.Kind == Sh9MessageKind.Error && e.Error.ToString() == "unauthorized: bad token", "error");
        checks.Expect("parser_accepts_valid", Sh9Protocol.Parse("{\"type\":\"pong\"}").Kind == Sh9MessageKind.Unknown, "unknown type");
        checks.Expect("subscribe_message", Sh9Protocol.SubscribeMessage("desk \"2\"", 30) ==
               "{\"type\":\"subscribe\",\"probe\":\"desk \\\"2\\\"\",\"max_hz\":30}", Sh9Protocol.SubscribeMessage("desk \"2\"", 30));
        checks.Expect("uri", Sh9Client.BuildUri("192.168.1.5:8765", "a b&c", true).AbsoluteUri == "ws://192.168.1.5:8765/?token=a%20b%26c",
               Sh9Client.BuildUri("192.168.1.5:8765", "a b&c", true).AbsoluteUri);
        checks.Expect("uri", Sh9Client.BuildUri("http://pc.local:8765", "t", false).AbsoluteUri == "ws://pc.local:8765/",
               Sh9Client.BuildUri("http://pc.local:8765", "t", false).AbsoluteUri);
        // Invariant culture: parsing must not depend on the thread's locale.
        System.Threading.Thread.CurrentThread.CurrentCulture = new CultureInfo("de-DE");
        checks.Expect("parser_invariant_culture", (double)MiniJson.Parse("0.5") == 0.5, "de-DE");
        System.Threading.Thread.CurrentThread.CurrentCulture = CultureInfo.InvariantCulture;
    }

    static int Main(string[] args)
    {
        int cases = 0;
        try
        {
            if (args.Length > 0)
            {
                Dictionary<string, object> doc = MiniJson.ParseObject(File.ReadAllText(args[0]));
                checks.Expect("vectors_header", Sh9Protocol.GetString(doc, "frame", "") == "rh-y-up", "frame");
                checks.Expect("vectors_header", (int)Sh9Protocol.GetNumber(doc, "version", 0) == 1, "version");
                var list = doc["cases"] as List<object>;
                foreach (object o in list)
                {
                    RunCase((Dictionary<string, object>)o);
                    cases++;
                }
            }
            OneSidedLights();
            ParserChecks();
            Lights();
            LightParserChecks();
            NoAllocation();
        }
        catch (Exception ex)
        {
            checks.Fail("exception: " + ex);
        }
        return checks.Report(cases);
    }
}
