// Issue 31: the C# core reads the photometric fields of an "sh9" message (docs/contract.md §14) and
// gives the exposure a physical camera sets for the room. Reads one message on stdin, prints one JSON
// object {"absolute": b, "units": s, "lux": x, "ev100": x, "exposure": x, "cct": x, "lights": k,
// "light_lux": [...]} (NaN printed as null).
using System;
using System.Globalization;
using System.Text;
using Shlight.Lighting;

static class PhotometryTest
{
    static string N(double v)
    {
        return double.IsNaN(v) ? "null" : v.ToString("R", CultureInfo.InvariantCulture);
    }

    static int Main()
    {
        string text = Console.In.ReadToEnd();
        Sh9Message m = Sh9Protocol.Parse(text).Sh9;
        var sb = new StringBuilder();
        sb.Append("{\"absolute\": ").Append(m.IsAbsolute ? "true" : "false");
        sb.Append(", \"units\": \"").Append(m.CoefficientUnits == "cd/m²" ? "cd/m2" : m.CoefficientUnits).Append('"');
        sb.Append(", \"lux\": ").Append(N(m.IlluminanceLux));
        sb.Append(", \"ev100\": ").Append(N(m.Ev100));
        sb.Append(", \"exposure\": ").Append(N(m.PhysicalExposure));
        sb.Append(", \"cct\": ").Append(N(m.CctK));
        sb.Append(", \"lights\": ").Append(m.Lights);
        sb.Append(", \"light_lux\": [");
        for (int i = 0; i < m.LightIlluminanceLux.Length; i++)
            sb.Append(i > 0 ? ", " : "").Append(N(m.LightIlluminanceLux[i]));
        sb.Append("]}");
        Console.WriteLine(sb.ToString());
        return 0;
    }
}
