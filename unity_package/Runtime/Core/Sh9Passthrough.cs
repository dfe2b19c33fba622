// The headset's passthrough camera on the consumer's side (docs/passthrough.md, docs/contract.md §15): the
// server's answers on /capture ("passthrough": a view's exposure and white balance; "passthrough_camera": the
// headset camera's inverse response g, a camera.json object) and the 256-entry display lookup the shaders
// render a hologram through, so that it shows the code its real replica shows in passthrough:
//     display code = g⁻¹(exposure · wb · linear colour).
// Plain C#, no UnityEngine: SH9LightingClient uploads it, the Mono tests check it against Python.
using System;
using System.Collections.Generic;
using System.Threading;

namespace Shlight.Lighting
{
    public enum Sh9PassthroughKind { Unknown = 0, Answer = 1, Camera = 2, Hello = 3, Error = 4 }

    /// <summary>One "passthrough" answer: the exposure and white balance of one view under the headset's
    /// current curve, or a view the server dropped.</summary>
    public sealed class Sh9PassthroughAnswer
    {
        /// <summary>The view's own "time" (as the headset sent it).</summary>
        public double Time = double.NaN;
        /// <summary>The view's index on its socket (-1 for a dropped view).</summary>
        public long View = -1;
        /// <summary>True when the server did not fit the view (<see cref="Reason"/>: "busy" or "rate").</summary>
        public bool Dropped;
        public string Reason;
        /// <summary>False when the view had no usable pixels (the last exposure, no white balance).</summary>
        public bool Fitted = true;
        /// <summary>Sphere radiance (its units) × Exposure = the camera's sensor exposure (green).</summary>
        public double Exposure = double.NaN;
        /// <summary>[r, g, b] white-balance gains, g = 1; null when not fitted.</summary>
        public double[] WbGains;
        public double Ev100 = double.NaN;
        public double ResidualStops = double.NaN;
        public int Samples;
        public bool Solved;
        public long DroppedViews;

        /// <summary>True when the answer carries an exposure and white balance a consumer can render with.</summary>
        public bool Usable { get { return !Dropped && Fitted && Exposure > 0 && WbGains != null; } }
    }

    /// <summary>The headset camera's inverse response and the display lookup built from it (docs/contract.md §15,
    /// "The display lookup").</summary>
    public sealed class Sh9PassthroughCamera
    {
        /// <summary>Entries of the lookup (a 256 × 1 texture in the shaders).</summary>
        public const int LutSize = 256;

        /// <summary>g_c(code) per channel [c][code], made non-decreasing (as the lookup inverts it).</summary>
        public readonly double[][] Table;
        /// <summary>log2 of the sensor exposure at entries 0 and LutSize − 1: Log2Lo of the smallest positive
        /// g_c(1), Log2Hi of the largest g_c(top), over the channels.</summary>
        public readonly double Log2Lo, Log2Hi;
        /// <summary>2^−Log2Lo: below entry 0 the shaders scale it by x · ToeScale (the linear toe to code 0).</summary>
        public readonly double ToeScale;
        /// <summary>LutSize × 4 floats (RGBA, A = 1): entry j, channel c is g_c⁻¹(2^(Log2Lo + (Log2Hi − Log2Lo)·j/255))
        /// / (codes − 1), the display value (an sRGB-encoded value in [0, 1]).</summary>
        public readonly float[] Lut = new float[4 * LutSize];
        /// <summary>The camera.json object as received.</summary>
        public readonly Dictionary<string, object> Json;

        Sh9PassthroughCamera(double[][] table, Dictionary<string, object> json)
        {
            Table = table;
            Json = json;
            int n = table[0].Length;
            double top = 0, first = double.PositiveInfinity;
            for (int c = 0; c < 3; c++)
            {
                double run = 0;
                for (int k = 0; k < n; k++) table[c][k] = run = Math.Max(run, table[c][k]);
                top = Math.Max(top, table[c][n - 1]);
                if (table[c][1] > 0) first = Math.Min(first, table[c][1]);
            }
            // the entries span the codes' own range, code 1 to the top (docs/contract.md §15, "The display lookup")
            if (double.IsInfinity(first) || !(top > first))
                throw new FormatException("camera: the table has no range (g(1) must be positive and below g(top))");
            Log2Lo = Math.Log(first, 2.0);
            Log2Hi = Math.Log(top, 2.0);
            ToeScale = 1.0 / first;
            for (int j = 0; j < LutSize; j++)
            {
                double x = Math.Pow(2.0, Log2Lo + (Log2Hi - Log2Lo) * j / (LutSize - 1));
                for (int c = 0; c < 3; c++) Lut[4 * j + c] = (float)(Inverse(c, x) / (n - 1));
                Lut[4 * j + 3] = 1f;
            }
        }

        /// <summary>The continuous code g_c⁻¹(x) of sensor exposure x, exactly (linear interpolation of the
        /// table, as numpy.interp: clamped to the first and last code).</summary>
        public double Inverse(int channel, double x)
        {
            double[] g = Table[channel];
            int n = g.Length;
            if (!(x > g[0])) return 0;
            if (x >= g[n - 1]) return n - 1;
            int lo = 0, hi = n - 1;               // g[lo] < x <= g[hi]
            while (hi - lo > 1)
            {
                int mid = (lo + hi) >> 1;
                if (g[mid] < x) lo = mid; else hi = mid;
            }
            double span = g[hi] - g[lo];
            return span > 0 ? lo + (x - g[lo]) / span : hi;
        }

        /// <summary>What the shaders' lookup gives for sensor exposure x in channel c (SH9DiffusePasses.hlsl,
        /// SH9_PASSTHROUGH): t = saturate((log2 x − Log2Lo) / (Log2Hi − Log2Lo)), the entries at t·255 linearly
        /// interpolated (a bilinear 256-texel texture sampled at texel centres), times min(x · ToeScale, 1) (below
        /// entry 0, linear in x down to code 0). A display value in [0, 1].</summary>
        public double Display(int channel, double x)
        {
            x = Math.Max(x, 0);
            double t = (Math.Log(Math.Max(x, 1e-30), 2.0) - Log2Lo) / (Log2Hi - Log2Lo);
            t = Math.Min(1.0, Math.Max(0.0, t)) * (LutSize - 1);
            int j = Math.Min((int)t, LutSize - 2);
            double f = t - j;
            return (Lut[4 * j + channel] * (1 - f) + Lut[4 * (j + 1) + channel] * f) * Math.Min(x * ToeScale, 1.0);
        }

        /// <summary>The camera of a camera.json object ("format" "shlight-camera-response", "table" {r, g, b}).</summary>
        public static Sh9PassthroughCamera FromJson(Dictionary<string, object> camera)
        {
            if (camera == null) throw new FormatException("camera: not an object");
            object format;
            if (camera.TryGetValue("format", out format) && format as string != "shlight-camera-response")
                throw new FormatException("camera: format is not shlight-camera-response");
            var table = camera.ContainsKey("table") ? camera["table"] as Dictionary<string, object> : null;
            if (table == null) throw new FormatException("camera: no table");
            var channels = new double[3][];
            string[] names = { "r", "g", "b" };
            for (int c = 0; c < 3; c++)
            {
                object v;
                var list = table.TryGetValue(names[c], out v) ? v as List<object> : null;
                if (list == null || list.Count < 2 || list.Count > 65536)
                    throw new FormatException("camera: table." + names[c] + " must be 2..65536 numbers");
                if (c > 0 && list.Count != channels[0].Length)
                    throw new FormatException("camera: the table's channels differ in length");
                channels[c] = new double[list.Count];
                for (int k = 0; k < list.Count; k++)
                {
                    if (!(list[k] is double) || double.IsNaN((double)list[k]) || double.IsInfinity((double)list[k]))
                        throw new FormatException("camera: table." + names[c] + "[" + k + "] is not a number");
                    channels[c][k] = (double)list[k];
                }
            }
            return new Sh9PassthroughCamera(channels, camera);
        }
    }

    /// <summary>Parses the answers of /capture.</summary>
    public static class Sh9PassthroughProtocol
    {
        /// <summary>Parse one text message of /capture. Answer and Camera fill <paramref name="answer"/> or
        /// <paramref name="camera"/>; Error puts "error: detail" in <paramref name="error"/>.</summary>
        public static Sh9PassthroughKind Parse(string text, out Sh9PassthroughAnswer answer,
                                              out Sh9PassthroughCamera camera, out string error)
        {
            answer = null;
            camera = null;
            error = null;
            Dictionary<string, object> m;
            try { m = MiniJson.ParseObject(text); }
            catch (FormatException e) { error = "not JSON: " + e.Message; return Sh9PassthroughKind.Unknown; }
            string type = Str(m, "type");
            switch (type)
            {
                case "passthrough":
                    var a = new Sh9PassthroughAnswer
                    {
                        Time = Num(m, "time"), View = (long)Num(m, "view", -1), Dropped = m.ContainsKey("dropped") && m["dropped"] is bool && (bool)m["dropped"],
                        Reason = Str(m, "reason"), Exposure = Num(m, "exposure"), Ev100 = Num(m, "ev100"),
                        ResidualStops = Num(m, "residual_stops"), Samples = (int)Num(m, "samples", 0),
                        Solved = m.ContainsKey("solved") && m["solved"] is bool && (bool)m["solved"],
                        DroppedViews = (long)Num(m, "dropped_views", 0),
                        Fitted = !(m.ContainsKey("fitted") && m["fitted"] is bool && !(bool)m["fitted"]),
                    };
                    object wb;
                    var list = m.TryGetValue("wb_gains", out wb) ? wb as List<object> : null;
                    if (list != null && list.Count == 3 && list[0] is double && list[1] is double && list[2] is double)
                        a.WbGains = new[] { (double)list[0], (double)list[1], (double)list[2] };
                    answer = a;
                    return Sh9PassthroughKind.Answer;
                case "passthrough_camera":
                    try { camera = Sh9PassthroughCamera.FromJson(m.ContainsKey("camera") ? m["camera"] as Dictionary<string, object> : null); }
                    catch (FormatException e) { error = e.Message; return Sh9PassthroughKind.Unknown; }
                    return Sh9PassthroughKind.Camera;
                case "hello":
                    return Sh9PassthroughKind.Hello;
                case "error":
                    error = Str(m, "error") + ": " + Str(m, "detail");
                    return Sh9PassthroughKind.Error;
                default:
                    return Sh9PassthroughKind.Unknown;
            }
        }

        static string Str(Dictionary<string, object> m, string key)
        {
            object v;
            return m.TryGetValue(key, out v) ? v as string : null;
        }

        static double Num(Dictionary<string, object> m, string key, double missing = double.NaN)
        {
            object v;
            return m.TryGetValue(key, out v) && v is double ? (double)v : missing;
        }
    }

    /// <summary>The latest usable answer and camera of one headset: written by the capture socket's receive
    /// thread, read by the main thread (one atomic reference each; <see cref="Version"/> counts changes).</summary>
    public sealed class Sh9PassthroughState
    {
        Sh9PassthroughAnswer answer;
        Sh9PassthroughCamera camera;
        long version, answers, dropped, errors;

        public Sh9PassthroughAnswer Answer { get { return Volatile.Read(ref answer); } }
        public Sh9PassthroughCamera Camera { get { return Volatile.Read(ref camera); } }
        /// <summary>Increases whenever the usable answer or the camera changes.</summary>
        public long Version { get { return Interlocked.Read(ref version); } }
        public long Answers { get { return Interlocked.Read(ref answers); } }
        public long Dropped { get { return Interlocked.Read(ref dropped); } }
        public long Errors { get { return Interlocked.Read(ref errors); } }
        /// <summary>The last error the server sent ("bad_view: ..."), or null.</summary>
        public string LastError { get; private set; }
        /// <summary>True once both an answer and a camera arrived: the shaders can render through them.</summary>
        public bool Ready { get { return Answer != null && Camera != null; } }

        /// <summary>Take one text message of /capture; returns its kind.</summary>
        public Sh9PassthroughKind Handle(string text)
        {
            Sh9PassthroughAnswer a;
            Sh9PassthroughCamera c;
            string error;
            Sh9PassthroughKind kind = Sh9PassthroughProtocol.Parse(text, out a, out c, out error);
            if (kind == Sh9PassthroughKind.Answer) Set(a);
            else if (kind == Sh9PassthroughKind.Camera) Set(c);
            else if (kind == Sh9PassthroughKind.Error)
            {
                Interlocked.Increment(ref errors);
                LastError = error;
            }
            return kind;
        }

        /// <summary>Keep <paramref name="a"/> when it is usable (a dropped or unfitted view keeps the last one).</summary>
        public void Set(Sh9PassthroughAnswer a)
        {
            if (a == null) return;
            Interlocked.Increment(ref answers);
            if (a.Dropped) Interlocked.Increment(ref dropped);
            if (!a.Usable) return;
            Volatile.Write(ref answer, a);
            Interlocked.Increment(ref version);
        }

        public void Set(Sh9PassthroughCamera c)
        {
            if (c == null) return;
            Volatile.Write(ref camera, c);
            Interlocked.Increment(ref version);
        }

        /// <summary>The shaders' gain per channel, exposure · wb_c · 2^compensation, into <paramref name="rgb"/>
        /// (3 values); false (and 1, 1, 1) before the first usable answer.</summary>
        public bool Gain(double compensationEv, double[] rgb)
        {
            Sh9PassthroughAnswer a = Answer;
            if (double.IsNaN(compensationEv) || double.IsInfinity(compensationEv)) compensationEv = 0;
            if (a == null)
            {
                rgb[0] = rgb[1] = rgb[2] = 1;
                return false;
            }
            double k = a.Exposure * Math.Pow(2.0, compensationEv);
            for (int c = 0; c < 3; c++) rgb[c] = k * a.WbGains[c];
            return true;
        }
    }
}
