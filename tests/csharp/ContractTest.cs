// Checks the package's C# core (unity_package/Runtime/Core) against contract test vectors
// (shaders/contract_vectors.json, or a file in the same format) and against one-sided lights.
// Built with Mono's mcs by tests/test_unity.py; prints one JSON object and exits 0 if every
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
    sealed class Check
    {
        public string Name;
        public double MaxAbs;   // max |got - want|
        public double MaxRel;   // max |got - want| / max |want| (scale-relative)
        public double Tolerance;
        public int Count;
        public bool Ok { get { return MaxRel <= Tolerance && !double.IsNaN(MaxRel); } }
    }

    // ñᵀMñ uses the 6-digit constants c1..c5 of Ramamoorthi & Hanrahan (DESIGN.md §2), so it
    // differs from Σ Â_l L_lm Y_lm(n) by up to ~7e-7 of the scale: the floor for every
    // irradiance comparison. Matrix and rotation algebra is checked to 1e-12.
    const double ConstantRounding = 2e-6;

    static readonly Dictionary<string, Check> checks = new Dictionary<string, Check>();
    static readonly List<string> failures = new List<string>();

    static void Compare(string name, double[] got, double[] want, double tolerance, string where)
    {
        if (got.Length != want.Length)
        {
            failures.Add(name + " [" + where + "]: length " + got.Length + " != " + want.Length);
            return;
        }
        double scale = 0, maxAbs = 0;
        foreach (double w in want) scale = Math.Max(scale, Math.Abs(w));
        for (int i = 0; i < got.Length; i++) maxAbs = Math.Max(maxAbs, Math.Abs(got[i] - want[i]));
        double rel = maxAbs / Math.Max(scale, 1e-300);
        if (scale == 0) rel = maxAbs;
        Check c;
        if (!checks.TryGetValue(name, out c)) checks[name] = c = new Check { Name = name, Tolerance = tolerance };
        c.MaxAbs = Math.Max(c.MaxAbs, maxAbs);
        c.MaxRel = Math.Max(c.MaxRel, rel);
        c.Count += got.Length;
        if (!(rel <= tolerance)) failures.Add(name + " [" + where + "]: rel error " + rel.ToString("E3") + " > " + tolerance);
    }

    static void Expect(string name, bool condition, string detail)
    {
        Check c;
        if (!checks.TryGetValue(name, out c)) checks[name] = c = new Check { Name = name, Tolerance = 0 };
        c.Count++;
        if (!condition) { c.MaxRel = 1; failures.Add(name + ": " + detail); }
    }

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

        // 1. the wire matrices follow from the coefficients (DESIGN.md §2)
        Compare("matrices_from_coefficients", Sh9Math.MatricesFromCoefficients(coeffs), mats, 1e-12, name);
        // 2. E(n) = ñᵀMñ, right-handed
        Compare("irradiance_rh", EvalMatrices(mats, normals), irr, ConstantRounding, name);
        // 3. frame conversion S M S, and E in Unity's frame at (x, y, -z)
        double[] myUnity = Sh9Math.MatricesToUnity(mats);
        Compare("unity_matrices", myUnity, umats, 1e-12, name);
        Compare("irradiance_unity", EvalMatrices(myUnity, unormals), irr, ConstantRounding, name);
        // 4. the message path: parse a wire message built from the case, snapshot, upload values
        string wire = "{\"type\":\"sh9\",\"version\":1,\"probe\":\"default\",\"seq\":1,\"time\":0,\"stale\":false," +
                      "\"frame\":\"rh-y-up\",\"coefficients\":" + JsonArray(coeffs) + ",\"matrices\":" + JsonArray(mats) + "}";
        Sh9Parsed parsed = Sh9Protocol.Parse(wire);
        var snap = new Sh9Snapshot(parsed.Sh9, 0, 1);
        Compare("message_roundtrip_unity_matrices", snap.UnityMatrices, umats, 1e-12, name);
        var values = new Sh9LightingValues();
        values.Set(snap.UnityMatrices, null, 1.0);
        Compare("upload_float32_irradiance", EvalMatrices(ToDouble(values.Matrices), unormals), irr, ConstantRounding, name);
        // 5. Unity ambient probe: ShadeSH9 on the converted SphericalHarmonicsL2 = E/π
        double[] want = Divide(irr, Math.PI);
        double[] probeFromCoeffs = Sh9Math.AmbientProbeFromCoefficients(snap.UnityCoefficients);
        double[] probeFromMats = Sh9Math.AmbientProbeFromMatrices(snap.UnityMatrices);
        Compare("ambient_shadesh9_from_coefficients", EvalShadeSH9(probeFromCoeffs, unormals), want, ConstantRounding, name);
        Compare("ambient_shadesh9_from_matrices", EvalShadeSH9(probeFromMats, unormals), want, ConstantRounding, name);
        Compare("ambient_paths_agree", probeFromMats, probeFromCoeffs, ConstantRounding, name);
        Compare("ambient_float32_upload", EvalShadeSH9(ToDouble(values.AmbientProbe), unormals), want, ConstantRounding, name);

        // 6. rotation cases: M' = R̃ M R̃ᵀ, in both frames; Unity's via a quaternion like transform.rotation
        if (cs.ContainsKey("rotation"))
        {
            double[] rot = Numbers(cs, "rotation");
            double[] rmats = Numbers(cs, "rotated_matrices");
            double[] urmats = Numbers(cs, "unity_rotated_matrices");
            Compare("rotated_matrices_rh", Sh9Math.RotateMatrices(mats, rot), rmats, 1e-12, name);
            double[] ur = Sh9Math.RotationToUnity(rot);
            Compare("rotated_matrices_unity", Sh9Math.RotateMatrices(umats, ur), urmats, 1e-12, name);
            double[] q = MatrixToQuaternion(ur);
            double[] fromQ = Sh9Math.QuaternionToMatrix(q[0], q[1], q[2], q[3]);
            Compare("quaternion_roundtrip", fromQ, ur, 1e-12, name);
            var rv = new Sh9LightingValues();
            rv.Set(snap.UnityMatrices, fromQ, 1.0);
            Compare("rotated_upload_float32", ToDouble(rv.Matrices), urmats, ConstantRounding, name);
            // E'(R n) = E(n): the rotated probe seen along the rotated normal
            int n = unormals.Length / 3;
            var rn = new double[unormals.Length];
            for (int k = 0; k < n; k++)
            {
                double[] v = Sh9Math.Rotate(ur, unormals[3 * k], unormals[3 * k + 1], unormals[3 * k + 2]);
                rn[3 * k] = v[0]; rn[3 * k + 1] = v[1]; rn[3 * k + 2] = v[2];
            }
            Compare("rotated_irradiance_unity", EvalMatrices(urmats, rn), irr, ConstantRounding, name);
            Compare("rotated_ambient_shadesh9", EvalShadeSH9(ToDouble(rv.AmbientProbe), rn), want, ConstantRounding, name);
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
        Expect("one_sided_light", fromMatrix == expectWorld,
               label + ": matrices brightest at " + fromMatrix + ", expected " + expectWorld);
        Expect("one_sided_light", fromAmbient == expectWorld,
               label + ": ambient probe brightest at " + fromAmbient + ", expected " + expectWorld);
        // the far side is darker than the lit side by a wide margin
        double[] d = { 0, 0, 0 };
        int axis = "xyz".IndexOf(expectWorld[1]);
        d[axis] = expectWorld[0] == '+' ? 1 : -1;
        double lit = Green(m, d[0], d[1], d[2]), dark = Green(m, -d[0], -d[1], -d[2]);
        Expect("one_sided_light", lit > 3 * dark, label + ": lit " + lit + " vs dark " + dark);
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
        Compare("intensity_multiplier", ToDouble(b.Matrices), Sh9Math.Scale(ToDouble(a.Matrices), 2.5), 1e-6, "2.5x");
        // Furnace: uniform radiance 1 gives E = π, ShadeSH9 = 1 (a white surface shows 1).
        var f = new Sh9LightingValues(); f.SetUniform(1, 1, 1);
        Compare("furnace", f.Irradiance(0.6, 0.8, 0), new[] { Math.PI, Math.PI, Math.PI }, 1e-6, "uniform");
        Compare("furnace", Sh9Math.ShadeSH9(Sh9Math.PackUnityShaderConstants(ToDouble(f.AmbientProbe)), 0, 0, 1),
                new double[] { 1, 1, 1 }, 1e-6, "uniform ShadeSH9");
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
            Expect("parser_rejects_invalid", threw, "accepted: " + (text.Length > 60 ? text.Substring(0, 60) + "..." : text));
        }
        // A full message with statistics, unicode and escapes, unknown fields and nesting is accepted.
        string good = "{\"type\":\"sh9\",\"version\":1,\"probe\":\"r\\u00e4um \\\"1\\\"\",\"seq\":42,\"time\":1700000000.25," +
                      "\"stale\":true,\"age_s\":0.5,\"frame\":\"rh-y-up\",\"coefficients\":" + JsonArray(Spot(1, 0, 0)) +
                      ",\"matrices\":" + JsonArray(Sh9Math.MatricesFromCoefficients(Spot(1, 0, 0))) +
                      ",\"compute_ms\":1.5E-1,\"min_irradiance\":[-0.1,0,1e-3],\"window_cutoff\":0,\"future\":{\"x\":[1,[2]]},\"note\":null}";
        Sh9Parsed p = Sh9Protocol.Parse(good);
        Expect("parser_accepts_valid", p.Kind == Sh9MessageKind.Sh9 && p.Sh9.Probe == "r\u00e4um \"1\"" && p.Sh9.Seq == 42
               && p.Sh9.Stale && p.Sh9.AgeSeconds == 0.5 && p.Sh9.ComputeMs == 0.15 && p.Sh9.MinIrradiance[0] == -0.1
               && p.Sh9.Time == 1700000000.25 && !p.Sh9.MatricesDerived, "full message");
        Sh9Parsed h = Sh9Protocol.Parse("{\"type\":\"hello\",\"version\":1,\"provider\":\"shlight 0.1\",\"frame\":\"rh-y-up\",\"probes\":[\"default\",\"desk\"]}");
        Expect("parser_accepts_valid", h.Kind == Sh9MessageKind.Hello && h.Hello.Probes.Length == 2 && h.Hello.Probes[1] == "desk", "hello");
        Sh9Parsed e = Sh9Protocol.Parse("{\"type\":\"error\",\"error\":\"unauthorized\",\"detail\":\"bad token\"}");
        Expect("parser_accepts_valid", e.Kind == Sh9MessageKind.Error && e.Error.ToString() == "unauthorized: bad token", "error");
        Expect("parser_accepts_valid", Sh9Protocol.Parse("{\"type\":\"pong\"}").Kind == Sh9MessageKind.Unknown, "unknown type");
        Expect("subscribe_message", Sh9Protocol.SubscribeMessage("desk \"2\"", 30) ==
               "{\"type\":\"subscribe\",\"probe\":\"desk \\\"2\\\"\",\"max_hz\":30}", Sh9Protocol.SubscribeMessage("desk \"2\"", 30));
        Expect("uri", Sh9Client.BuildUri("192.168.1.5:8765", "a b&c", true).AbsoluteUri == "ws://192.168.1.5:8765/?token=a%20b%26c",
               Sh9Client.BuildUri("192.168.1.5:8765", "a b&c", true).AbsoluteUri);
        Expect("uri", Sh9Client.BuildUri("http://pc.local:8765", "t", false).AbsoluteUri == "ws://pc.local:8765/",
               Sh9Client.BuildUri("http://pc.local:8765", "t", false).AbsoluteUri);
        // Invariant culture: parsing must not depend on the thread's locale.
        System.Threading.Thread.CurrentThread.CurrentCulture = new CultureInfo("de-DE");
        Expect("parser_invariant_culture", (double)MiniJson.Parse("0.5") == 0.5, "de-DE");
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
                Expect("vectors_header", Sh9Protocol.GetString(doc, "frame", "") == "rh-y-up", "frame");
                Expect("vectors_header", (int)Sh9Protocol.GetNumber(doc, "version", 0) == 1, "version");
                var list = doc["cases"] as List<object>;
                foreach (object o in list)
                {
                    RunCase((Dictionary<string, object>)o);
                    cases++;
                }
            }
            OneSidedLights();
            ParserChecks();
        }
        catch (Exception ex)
        {
            failures.Add("exception: " + ex);
        }
        var sb = new StringBuilder();
        sb.Append("{\"cases\":").Append(cases).Append(",\"checks\":{");
        bool first = true;
        foreach (Check c in checks.Values)
        {
            if (!first) sb.Append(',');
            first = false;
            sb.Append(MiniJson.Quote(c.Name)).Append(":{\"max_abs\":").Append(MiniJson.Number(c.MaxAbs))
              .Append(",\"max_rel\":").Append(MiniJson.Number(c.MaxRel)).Append(",\"tolerance\":")
              .Append(MiniJson.Number(c.Tolerance)).Append(",\"n\":").Append(c.Count)
              .Append(",\"ok\":").Append(c.Ok ? "true" : "false").Append('}');
        }
        sb.Append("},\"failures\":[");
        for (int i = 0; i < failures.Count; i++)
        {
            if (i > 0) sb.Append(',');
            sb.Append(MiniJson.Quote(failures[i]));
        }
        sb.Append("]}");
        Console.WriteLine(sb.ToString());
        return failures.Count == 0 ? 0 : 1;
    }
}
