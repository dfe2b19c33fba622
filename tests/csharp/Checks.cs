// What the C# test programs (ContractTest.cs, ExportTest.cs) share: named checks that keep
// their worst error, the list of failures, and the one-line JSON report that
// tests/clients/unity/test_unity.py and tests/clients/unity/test_export_unity.py read:
//   {"cases": N, "checks": {name: {"max_abs", "max_rel", "tolerance", "count", "ok"}},
//    "failures": [...]}
using System;
using System.Collections.Generic;
using System.Text;
using Shlight.Lighting;

sealed class Checks
{
    sealed class Check
    {
        public double MaxAbs;   // max |got - want|
        public double MaxRel;   // max |got - want| / scale (see Checks(scaleFloor))
        public double Tolerance;
        public int Count;
        public bool Ok { get { return MaxRel <= Tolerance && !double.IsNaN(MaxRel); } }
    }

    readonly Dictionary<string, Check> checks = new Dictionary<string, Check>();
    readonly List<string> failures = new List<string>();
    readonly double scaleFloor;

    /// <summary>Errors are relative to max(max |want|, <paramref name="scaleFloor"/>), and
    /// absolute where that is 0: a floor of 1 measures vectors of scale about 1 absolutely
    /// near 0; a floor of 0 is purely scale-relative.</summary>
    public Checks(double scaleFloor)
    {
        this.scaleFloor = scaleFloor;
    }

    Check Get(string name, double tolerance)
    {
        Check c;
        if (!checks.TryGetValue(name, out c)) checks[name] = c = new Check { Tolerance = tolerance };
        return c;
    }

    /// <summary>Compares two equal-length vectors; fails when the error exceeds
    /// <paramref name="tolerance"/>. <paramref name="where"/> names the case in a failure.</summary>
    public void Compare(string name, double[] got, double[] want, double tolerance, string where)
    {
        if (got.Length != want.Length)
        {
            failures.Add(name + " [" + where + "]: length " + got.Length + " != " + want.Length);
            return;
        }
        double scale = 0, maxAbs = 0;
        foreach (double w in want) scale = Math.Max(scale, Math.Abs(w));
        for (int i = 0; i < got.Length; i++) maxAbs = Math.Max(maxAbs, Math.Abs(got[i] - want[i]));
        double denominator = Math.Max(scale, scaleFloor);
        double rel = denominator > 0 ? maxAbs / denominator : maxAbs;
        Check c = Get(name, tolerance);
        c.MaxAbs = Math.Max(c.MaxAbs, maxAbs);
        c.MaxRel = Math.Max(c.MaxRel, rel);
        c.Count += got.Length;
        if (!(rel <= tolerance)) failures.Add(name + " [" + where + "]: error " + rel.ToString("E3") + " > " + tolerance);
    }

    /// <summary>A yes/no check: fails with <paramref name="detail"/> unless <paramref name="ok"/>.</summary>
    public void Expect(string name, bool ok, string detail)
    {
        Check c = Get(name, 0);
        c.Count++;
        if (!ok) { c.MaxRel = 1; failures.Add(name + ": " + detail); }
    }

    /// <summary>A failure outside any named check (an exception, say).</summary>
    public void Fail(string message)
    {
        failures.Add(message);
    }

    /// <summary>Prints the report on one line; returns the exit code: 0 when nothing failed.</summary>
    public int Report(int cases)
    {
        var sb = new StringBuilder();
        sb.Append("{\"cases\":").Append(cases).Append(",\"checks\":{");
        bool first = true;
        foreach (KeyValuePair<string, Check> kv in checks)
        {
            if (!first) sb.Append(',');
            first = false;
            Check c = kv.Value;
            sb.Append(MiniJson.Quote(kv.Key)).Append(":{\"max_abs\":").Append(MiniJson.Number(c.MaxAbs))
              .Append(",\"max_rel\":").Append(MiniJson.Number(c.MaxRel))
              .Append(",\"tolerance\":").Append(MiniJson.Number(c.Tolerance))
              .Append(",\"count\":").Append(c.Count)
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
