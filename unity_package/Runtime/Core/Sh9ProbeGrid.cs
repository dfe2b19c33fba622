// The server's grid of light between its probes (/probe-grid.json, docs/probes.md "In the engines"),
// turned into what Unity's LightProbes hold (plain C#, no UnityEngine): each point's position and its
// SH9 in Unity's left-handed frame and SphericalHarmonicsL2 layout, by the same conversion the ambient
// probe takes (Sh9Math.CoefficientsToUnity, then Sh9Math.AmbientProbeFromCoefficients).
//
// Frames: the wire's world frame is right-handed, y up (docs/contract.md §1); Unity's is the same with
// z negated, so a box typed in Unity's frame is asked for with its z bounds swapped and negated.
using System;
using System.Collections.Generic;
using System.Globalization;

namespace Shlight.Lighting
{
    public sealed class Sh9ProbeGrid
    {
        /// <summary>Points along x, y, z (x fastest, then y, then z), as the server counted them.</summary>
        public int[] Counts { get; private set; }
        /// <summary>How the server computed the light: "parallax" (through the room) or "tetrahedra"/"hull".</summary>
        public string Method { get; private set; }
        /// <summary>The points in Unity's frame: 3 per point (x, y, z).</summary>
        public double[] UnityPositions { get; private set; }
        /// <summary>Each point's SphericalHarmonicsL2 values: 27 per point, layout 9*rgb + i (Sh9Math).</summary>
        public double[] UnityProbes { get; private set; }
        /// <summary>The wire's coefficients as sent: 27 per point, index 3*i + c.</summary>
        public double[] Coefficients { get; private set; }
        public int Count { get { return UnityPositions.Length / 3; } }

        /// <summary>
        /// The /probe-grid.json address on the server of <paramref name="serverUrl"/> (ws://, wss://, http://,
        /// https:// or HOST:PORT) for a box in Unity's frame, with the token in the query if asked.
        /// </summary>
        public static Uri GridUri(string serverUrl, string token, bool tokenInQuery,
                                  double[] unityMin, double[] unityMax, double step)
        {
            if (unityMin == null || unityMin.Length != 3 || unityMax == null || unityMax.Length != 3)
                throw new ArgumentException("the box needs three numbers for min and for max");
            if (!(step > 0) || double.IsInfinity(step)) throw new ArgumentException("step must be a positive number");
            var b = new UriBuilder(Sh9Client.BuildUri(serverUrl, token, tokenInQuery));
            b.Scheme = b.Scheme == "wss" ? "https" : "http";
            b.Path = "/probe-grid.json";
            // z flips between the frames: Unity's [z0, z1] is the wire's [-z1, -z0]
            string q = "min=" + Triple(unityMin[0], unityMin[1], -unityMax[2]) +
                       "&max=" + Triple(unityMax[0], unityMax[1], -unityMin[2]) +
                       "&step=" + step.ToString("R", CultureInfo.InvariantCulture);
            string old = b.Query.TrimStart('?');
            b.Query = old.Length == 0 ? q : old + "&" + q;
            return b.Uri;
        }

        static string Triple(double x, double y, double z)
        {
            return x.ToString("R", CultureInfo.InvariantCulture) + "," + y.ToString("R", CultureInfo.InvariantCulture) +
                "," + z.ToString("R", CultureInfo.InvariantCulture);
        }

        /// <summary>Parse a "probe-grid" answer; throws <see cref="FormatException"/> on anything else.</summary>
        public static Sh9ProbeGrid Parse(string json)
        {
            Dictionary<string, object> o;
            try { o = MiniJson.ParseObject(json); }
            catch (Exception e) { throw new FormatException("the grid is not JSON: " + e.Message); }
            object type;
            if (!o.TryGetValue("type", out type) || !"probe-grid".Equals(type))
                throw new FormatException("not a probe-grid answer");
            double[] counts = Numbers(o, "counts"), positions = Numbers(o, "positions"),
                     coefficients = Numbers(o, "coefficients");
            if (counts.Length != 3) throw new FormatException("counts must hold three numbers");
            int n = 1;
            var c = new int[3];
            for (int i = 0; i < 3; i++)
            {
                if (counts[i] < 1 || counts[i] != Math.Floor(counts[i])) throw new FormatException("counts must be positive integers");
                c[i] = (int)counts[i];
                n *= c[i];
            }
            if (positions.Length != 3 * n || coefficients.Length != 27 * n)
                throw new FormatException("positions and coefficients do not match counts");
            var grid = new Sh9ProbeGrid { Counts = c, Coefficients = coefficients };
            object method;
            grid.Method = o.TryGetValue("method", out method) ? method as string : null;
            var unityPositions = new double[3 * n];
            var probes = new double[27 * n];
            var one = new double[27];
            for (int p = 0; p < n; p++)
            {
                unityPositions[3 * p] = positions[3 * p];
                unityPositions[3 * p + 1] = positions[3 * p + 1];
                unityPositions[3 * p + 2] = -positions[3 * p + 2];
                Array.Copy(coefficients, 27 * p, one, 0, 27);
                Array.Copy(Sh9Math.AmbientProbeFromCoefficients(Sh9Math.CoefficientsToUnity(one)), 0, probes, 27 * p, 27);
            }
            grid.UnityPositions = unityPositions;
            grid.UnityProbes = probes;
            return grid;
        }

        /// <summary>Whether the points sit where <paramref name="other"/>'s do (then Unity need not re-tetrahedralise).</summary>
        public bool SamePositions(Sh9ProbeGrid other)
        {
            if (other == null || other.UnityPositions.Length != UnityPositions.Length) return false;
            for (int i = 0; i < UnityPositions.Length; i++)
                if (other.UnityPositions[i] != UnityPositions[i]) return false;
            return true;
        }

        static double[] Numbers(Dictionary<string, object> o, string key)
        {
            object v;
            var list = o.TryGetValue(key, out v) ? v as List<object> : null;
            if (list == null) throw new FormatException(key + " must be an array of numbers");
            var r = new double[list.Count];
            for (int i = 0; i < r.Length; i++)
            {
                if (!(list[i] is double)) throw new FormatException(key + " must be an array of numbers");
                r[i] = (double)list[i];
                if (double.IsNaN(r[i]) || double.IsInfinity(r[i])) throw new FormatException(key + " must be finite");
            }
            return r;
        }
    }
}
