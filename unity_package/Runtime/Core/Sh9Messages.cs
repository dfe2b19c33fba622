// The wire contract (docs/contract.md §3) as typed C# objects: "sh9", "hello" and "error" messages.
// Plain C#: no UnityEngine, no reflection, no JsonUtility (works under IL2CPP/UWP).
using System;
using System.Collections.Generic;

namespace Shlight.Lighting
{
    public enum Sh9MessageKind { Sh9, Hello, Error, Unknown, Environment }

    /// <summary>One "sh9" coefficient message, exactly as sent (right-handed, +Y-up frame).</summary>
    public sealed class Sh9Message
    {
        public const int SupportedVersion = 1;
        public const string WireFrame = "rh-y-up";

        public int Version;
        public string Probe;
        public long Seq;
        /// <summary>Unix seconds of the frame the coefficients were computed from.</summary>
        public double Time;
        /// <summary>True while the source is lost: these are the last known coefficients.</summary>
        public bool Stale;
        /// <summary>Seconds between capture and sending (0 when the server does not say).</summary>
        public double AgeSeconds;
        public string Frame;
        /// <summary>27 raw radiance SH projections, wire order L00.r, L00.g, L00.b, L1-1.r, ...</summary>
        public double[] Coefficients;
        /// <summary>48 numbers: M_red, M_green, M_blue, row-major; E(n) = [n,1]ᵀ M [n,1].</summary>
        public double[] Matrices;
        /// <summary>True when the message had no "matrices" and they were computed from the coefficients.</summary>
        public bool MatricesDerived;
        /// <summary>Optional statistics (NaN / null when absent).</summary>
        public double ComputeMs = double.NaN;
        public double Fps = double.NaN;
        public double WindowCutoff;
        public double[] MinIrradiance;

        // Lights (docs/contract.md §10). Coefficients/Matrices above stay the full SH9 of everything;
        // these split it into an ambient SH9 plus directional lights.
        /// <summary>Number of directional lights k (0 when the scene needs none or the server does not send lights).</summary>
        public int Lights;
        /// <summary>3k numbers: unit vectors toward each light, right-handed wire frame (normalised here).</summary>
        public double[] LightDirections = EmptyNumbers;
        /// <summary>3k numbers: RGB irradiance on a surface facing each light.</summary>
        public double[] LightIrradiance = EmptyNumbers;
        /// <summary>k numbers, degrees: the radius of the disc that stands for each light as a shadow caster
        /// ("light_angular_radius_deg"); zeros (hard shadows) when the server does not send them.</summary>
        public double[] LightAngularRadiusDeg = EmptyNumbers;
        /// <summary>True when the message carried "light_angular_radius_deg".</summary>
        public bool HasLightAngularRadius;
        /// <summary>27 numbers: SH9 of everything but the lights (null when not sent or sent empty).</summary>
        public double[] AmbientCoefficients;
        /// <summary>48 numbers: irradiance matrices of <see cref="AmbientCoefficients"/> (derived when only
        /// the coefficients were sent; null when neither was).</summary>
        public double[] AmbientMatrices;

        /// <summary>True when the message carries at least one light and the ambient SH9 that goes with
        /// it, i.e. when a client can show the lights as lights without counting them twice.</summary>
        public bool HasLightSplit { get { return Lights > 0 && AmbientMatrices != null; } }

        // Photometry (docs/contract.md §14, docs/photometry.md): present when the provider's camera has
        // an absolute scale ("cd/m²"); NaN (or "relative") otherwise.
        /// <summary>"cd/m²" (absolute: coefficients in cd/m², irradiance in lux) or "relative".</summary>
        public string CoefficientUnits = "relative";
        /// <summary>Illuminance on an up-facing surface at the probe, lux (absolute only; NaN otherwise).</summary>
        public double IlluminanceLux = double.NaN;
        /// <summary>The EV100 a reflected-light meter sets for the room (absolute only; NaN otherwise).</summary>
        public double Ev100 = double.NaN;
        /// <summary>Correlated colour temperature of the mean radiance, kelvin (NaN when it has none).</summary>
        public double CctK = double.NaN;
        /// <summary>Duv of the mean radiance (NaN with <see cref="CctK"/>).</summary>
        public double Duv = double.NaN;
        /// <summary>k numbers: each light's illuminance at normal incidence, lux (absolute only; empty otherwise).</summary>
        public double[] LightIlluminanceLux = EmptyNumbers;
        /// <summary>k numbers: each light's CCT in kelvin, 0 where it has none.</summary>
        public double[] LightCctK = EmptyNumbers;

        /// <summary>True when the coefficients are in cd/m² (and the lux fields are present).</summary>
        public bool IsAbsolute { get { return CoefficientUnits == "cd/m²" && !double.IsNaN(Ev100); } }

        /// <summary>The exposure multiplier a physical camera uses for this room, 1 / (1.2 · 2^EV100) (HDRP's
        /// ConvertEV100ToExposure; for a fixed exposure set the camera's EV100 to <see cref="Ev100"/>);
        /// NaN for relative lighting.</summary>
        public double PhysicalExposure { get { return Sh9Photometry.ExposureFromEv100(Ev100); } }

        internal static readonly double[] EmptyNumbers = new double[0];
        /// <summary>The marker registration of docs/contract.md §13 (null until the server knows it).</summary>
        public Sh9Registration Registration;

        /// <summary>Every field of the message as parsed (numbers are double, arrays List&lt;object&gt;).</summary>
        public Dictionary<string, object> Fields;
    }

    /// <summary>Photometric conversions (docs/photometry.md).</summary>
    public static class Sh9Photometry
    {
        /// <summary>1 / (1.2 · 2^EV100): the saturation-based exposure of a camera at ISO 100 (Unity HDRP's
        /// ColorUtils.ConvertEV100ToExposure, Filament's exposure()); NaN for a NaN EV100.</summary>
        public static double ExposureFromEv100(double ev100)
        {
            if (double.IsNaN(ev100) || double.IsInfinity(ev100)) return double.NaN;
            return 1.0 / (1.2 * Math.Pow(2.0, ev100));
        }
    }

    /// <summary>The "hello" message a server sends first.</summary>
    public sealed class Sh9Hello
    {
        public int Version;
        public string Provider;
        public string Frame;
        public string[] Probes;
    }

    /// <summary>The JSON half of a cube update (docs/contract.md §12, Transport).</summary>
    public sealed class Sh9EnvironmentAnnouncement
    {
        public string Probe, Encoding, Frame;
        public long Seq, Sh9Seq, ByteLength;
        public int Size;
    }

    /// <summary>An "error" message (bad token, unknown probe, ...).</summary>
    public sealed class Sh9Error
    {
        public string Error;
        public string Detail;

        public override string ToString()
        {
            return string.IsNullOrEmpty(Detail) ? Error : Error + ": " + Detail;
        }
    }

    /// <summary>Result of <see cref="Sh9Protocol.Parse"/>: exactly one of the three is set.</summary>
    public sealed class Sh9Parsed
    {
        public Sh9MessageKind Kind;
        public Sh9Message Sh9;
        public Sh9Hello Hello;
        public Sh9Error Error;
        /// <summary>An "environment" message: a binary frame of <see cref="Sh9EnvironmentAnnouncement.ByteLength"/>
        /// bytes (the KTX2 cube) follows at once.</summary>
        public Sh9EnvironmentAnnouncement Environment;
        /// <summary>The "type" field for Unknown messages.</summary>
        public string Type;
    }

    /// <summary>Parses and validates wire messages; builds the messages a client sends.</summary>
    public static class Sh9Protocol
    {
        /// <summary>
        /// Parse one text frame. Throws <see cref="FormatException"/> (with a readable reason) for
        /// invalid JSON, a wrong version or frame, wrong array lengths or non-finite numbers.
        /// Unknown message types are returned as <see cref="Sh9MessageKind.Unknown"/>, not errors.
        /// </summary>
        public static Sh9Parsed Parse(string text)
        {
            Dictionary<string, object> obj = MiniJson.ParseObject(text);
            string type = GetString(obj, "type", null);
            if (type == null) throw new FormatException("message has no \"type\"");
            var result = new Sh9Parsed { Type = type };
            switch (type)
            {
                case "sh9":
                    result.Kind = Sh9MessageKind.Sh9;
                    result.Sh9 = ParseSh9(obj);
                    break;
                case "hello":
                    result.Kind = Sh9MessageKind.Hello;
                    result.Hello = ParseHello(obj);
                    break;
                case "error":
                    result.Kind = Sh9MessageKind.Error;
                    result.Error = new Sh9Error
                    {
                        Error = GetString(obj, "error", "error"),
                        Detail = GetString(obj, "detail", "")
                    };
                    break;
                case "environment":
                    result.Kind = Sh9MessageKind.Environment;
                    result.Environment = new Sh9EnvironmentAnnouncement
                    {
                        Probe = GetString(obj, "probe", "default"),
                        Seq = (long)GetNumber(obj, "seq", -1),
                        Sh9Seq = (long)GetNumber(obj, "sh9_seq", -1),
                        Size = (int)GetNumber(obj, "size", 0),
                        ByteLength = (long)GetNumber(obj, "byte_length", -1),
                        Encoding = GetString(obj, "encoding", "ktx2"),
                        Frame = GetString(obj, "frame", Sh9Message.WireFrame),
                    };
                    break;
                default:
                    result.Kind = Sh9MessageKind.Unknown;
                    break;
            }
            return result;
        }

        static Sh9Message ParseSh9(Dictionary<string, object> obj)
        {
            var m = new Sh9Message { Fields = obj };
            m.Version = (int)GetNumber(obj, "version", Sh9Message.SupportedVersion);
            if (m.Version != Sh9Message.SupportedVersion)
                throw new FormatException("unsupported message version " + m.Version +
                                          " (this client understands version " + Sh9Message.SupportedVersion + ")");
            m.Frame = GetString(obj, "frame", Sh9Message.WireFrame);
            if (m.Frame != Sh9Message.WireFrame)
                throw new FormatException("unsupported frame \"" + m.Frame + "\" (expected \"" + Sh9Message.WireFrame + "\")");
            m.Probe = GetString(obj, "probe", "default");
            m.Seq = (long)GetNumber(obj, "seq", 0);
            m.Time = GetNumber(obj, "time", 0);
            m.Stale = GetBool(obj, "stale", false);
            m.AgeSeconds = GetNumber(obj, "age_s", 0);
            m.ComputeMs = GetNumber(obj, "compute_ms", double.NaN);
            m.Fps = GetNumber(obj, "fps", double.NaN);
            m.WindowCutoff = GetNumber(obj, "window_cutoff", 0);
            m.MinIrradiance = GetNumbers(obj, "min_irradiance", 3, false);
            m.Coefficients = GetNumbers(obj, "coefficients", 27, true);
            m.Matrices = GetNumbers(obj, "matrices", 48, false);
            if (m.Matrices == null)
            {
                m.Matrices = Sh9Math.MatricesFromCoefficients(m.Coefficients);
                m.MatricesDerived = true;
            }
            ParseLights(obj, m);
            ParsePhotometry(obj, m);
            m.Registration = Sh9Registration.Parse(obj);
            return m;
        }

        // docs/contract.md §14: optional; a light's arrays have k numbers when present.
        static void ParsePhotometry(Dictionary<string, object> obj, Sh9Message m)
        {
            m.CoefficientUnits = GetString(obj, "coefficient_units", "relative");
            m.IlluminanceLux = GetNumber(obj, "illuminance_lux", double.NaN);
            m.Ev100 = GetNumber(obj, "ev100", double.NaN);
            m.CctK = GetNumber(obj, "cct_k", double.NaN);
            m.Duv = GetNumber(obj, "duv", double.NaN);
            double[] lux = GetNumbers(obj, "light_illuminance_lux", 0, false);
            double[] cct = GetNumbers(obj, "light_cct_k", 0, false);
            if (lux != null && lux.Length != m.Lights)
                throw new FormatException("\"light_illuminance_lux\" must have lights = " + m.Lights + " numbers, got " + lux.Length);
            if (cct != null && cct.Length != m.Lights)
                throw new FormatException("\"light_cct_k\" must have lights = " + m.Lights + " numbers, got " + cct.Length);
            m.LightIlluminanceLux = lux ?? Sh9Message.EmptyNumbers;
            m.LightCctK = cct ?? Sh9Message.EmptyNumbers;
        }

        /// <summary>Most lights a message may carry (a bound for hostile input; the provider sends a few).</summary>
        public const int MaxLights = 64;

        // docs/contract.md §10: "lights": k, "light_directions": [3k], "light_irradiance": [3k],
        // "ambient_coefficients": [27], "ambient_matrices": [48]. With k = 0 the arrays are empty and
        // the ambient_* fields may be absent or empty.
        static void ParseLights(Dictionary<string, object> obj, Sh9Message m)
        {
            double k = GetNumber(obj, "lights", 0);
            if (k < 0 || k > MaxLights || k != Math.Floor(k))
                throw new FormatException("\"lights\" must be a whole number from 0 to " + MaxLights + ", got " +
                                          MiniJson.Number(k));
            m.Lights = (int)k;
            double[] dirs = GetNumbers(obj, "light_directions", 0, false) ?? Sh9Message.EmptyNumbers;
            double[] irr = GetNumbers(obj, "light_irradiance", 0, false) ?? Sh9Message.EmptyNumbers;
            if (dirs.Length != 3 * m.Lights)
                throw new FormatException("\"light_directions\" must have 3 × lights = " + 3 * m.Lights +
                                          " numbers, got " + dirs.Length);
            if (irr.Length != 3 * m.Lights)
                throw new FormatException("\"light_irradiance\" must have 3 × lights = " + 3 * m.Lights +
                                          " numbers, got " + irr.Length);
            for (int i = 0; i < m.Lights; i++)
            {
                double x = dirs[3 * i], y = dirs[3 * i + 1], z = dirs[3 * i + 2];
                double n = Math.Sqrt(x * x + y * y + z * z);
                // a unit vector on the wire; accept float rounding, refuse anything that is not a direction
                if (!(n > 0.5 && n < 2.0))
                    throw new FormatException("\"light_directions\"[" + i + "] is not a unit vector (length " +
                                              MiniJson.Number(n) + ")");
                dirs[3 * i] = x / n; dirs[3 * i + 1] = y / n; dirs[3 * i + 2] = z / n;
                for (int c = 0; c < 3; c++)
                    if (irr[3 * i + c] < 0)
                        throw new FormatException("\"light_irradiance\"[" + (3 * i + c) + "] is negative (" +
                                                  MiniJson.Number(irr[3 * i + c]) + ")");
            }
            m.LightDirections = dirs;
            m.LightIrradiance = irr;
            // "light_angular_radius_deg": [k] degrees in [0, 90] (issue 30); absent from older servers
            double[] radii = GetNumbers(obj, "light_angular_radius_deg", 0, false);
            m.HasLightAngularRadius = radii != null && (radii.Length > 0 || m.Lights == 0);
            if (!m.HasLightAngularRadius) radii = new double[m.Lights];
            if (radii.Length != m.Lights)
                throw new FormatException("\"light_angular_radius_deg\" must have one number per light (" + m.Lights +
                                          "), got " + radii.Length);
            for (int i = 0; i < m.Lights; i++)
                if (!(radii[i] >= 0 && radii[i] <= 90))
                    throw new FormatException("\"light_angular_radius_deg\"[" + i + "] must be degrees in [0, 90], got " +
                                              MiniJson.Number(radii[i]));
            m.LightAngularRadiusDeg = radii;
            m.AmbientCoefficients = GetOptionalNumbers(obj, "ambient_coefficients", 27);
            m.AmbientMatrices = GetOptionalNumbers(obj, "ambient_matrices", 48);
            if (m.AmbientMatrices == null && m.AmbientCoefficients != null)
                m.AmbientMatrices = Sh9Math.MatricesFromCoefficients(m.AmbientCoefficients);
        }

        // Absent, null or [] all mean "not sent"; anything else must have exactly `length` numbers.
        static double[] GetOptionalNumbers(Dictionary<string, object> obj, string key, int length)
        {
            double[] v = GetNumbers(obj, key, 0, false);
            if (v == null || v.Length == 0) return null;
            if (v.Length != length)
                throw new FormatException("\"" + key + "\" must have " + length + " numbers (or be empty), got " + v.Length);
            return v;
        }

        static Sh9Hello ParseHello(Dictionary<string, object> obj)
        {
            var h = new Sh9Hello
            {
                Version = (int)GetNumber(obj, "version", 1),
                Provider = GetString(obj, "provider", ""),
                Frame = GetString(obj, "frame", Sh9Message.WireFrame),
            };
            var probes = new List<string>();
            object raw;
            if (obj.TryGetValue("probes", out raw) && raw is List<object>)
            {
                foreach (object p in (List<object>)raw)
                    if (p is string) probes.Add((string)p);
            }
            h.Probes = probes.ToArray();
            return h;
        }

        /// <summary>The subscribe request: {"type":"subscribe","probe":...,"max_hz":...}.</summary>
        public static string SubscribeMessage(string probe, double maxHz)
        {
            return SubscribeMessage(probe, maxHz, false);
        }

        /// <summary>The subscribe request; with <paramref name="environment"/> also "environment": true
        /// (docs/contract.md §12: the reflection cube as an "environment" message and a binary KTX2 frame).</summary>
        public static string SubscribeMessage(string probe, double maxHz, bool environment)
        {
            string text = "{\"type\":\"subscribe\",\"probe\":" + MiniJson.Quote(probe ?? "default");
            if (maxHz > 0) text += ",\"max_hz\":" + MiniJson.Number(maxHz);
            if (environment) text += ",\"environment\":true";
            return text + "}";
        }

        // ---- typed field access -------------------------------------------------------------

        public static string GetString(Dictionary<string, object> obj, string key, string fallback)
        {
            object v;
            if (!obj.TryGetValue(key, out v) || v == null) return fallback;
            var s = v as string;
            if (s == null) throw new FormatException("\"" + key + "\" must be a string");
            return s;
        }

        public static double GetNumber(Dictionary<string, object> obj, string key, double fallback)
        {
            object v;
            if (!obj.TryGetValue(key, out v) || v == null) return fallback;
            if (!(v is double)) throw new FormatException("\"" + key + "\" must be a number");
            return (double)v;
        }

        public static bool GetBool(Dictionary<string, object> obj, string key, bool fallback)
        {
            object v;
            if (!obj.TryGetValue(key, out v) || v == null) return fallback;
            if (!(v is bool)) throw new FormatException("\"" + key + "\" must be true or false");
            return (bool)v;
        }

        /// <summary>A flat array of numbers of exactly <paramref name="length"/> (any length if &lt;= 0).</summary>
        public static double[] GetNumbers(Dictionary<string, object> obj, string key, int length, bool required)
        {
            object v;
            if (!obj.TryGetValue(key, out v) || v == null)
            {
                if (required) throw new FormatException("message has no \"" + key + "\"");
                return null;
            }
            var list = v as List<object>;
            if (list == null) throw new FormatException("\"" + key + "\" must be an array of numbers");
            if (length > 0 && list.Count != length)
                throw new FormatException("\"" + key + "\" must have " + length + " numbers, got " + list.Count);
            var result = new double[list.Count];
            for (int i = 0; i < list.Count; i++)
            {
                if (!(list[i] is double)) throw new FormatException("\"" + key + "\"[" + i + "] is not a number");
                result[i] = (double)list[i];
            }
            return result;
        }
    }
}
