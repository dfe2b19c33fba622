// What the Mono test drivers share (PointLightTest.cs, ProbeGridTest.cs, PassthroughTest.cs; the tests compile
// it with each through tests/unitytools.py): Unity's calls of a component's messages, made by reflection as
// Unity makes them; the drivers' arguments and JSON numbers in the invariant culture; frames played until a
// condition holds. Nothing of UnityEngine here: the drivers built from the package's core alone use it too.
using System;
using System.Collections.Generic;
using System.Globalization;
using System.Reflection;
using System.Text;
using System.Threading;

static class Harness
{
    const BindingFlags Members = BindingFlags.Instance | BindingFlags.NonPublic | BindingFlags.Public;

    /// <summary>Unity's call of a message (OnEnable, Update, OnDisable, ...), private or not.</summary>
    public static void Call(object target, string method)
    {
        MethodInfo m = target.GetType().GetMethod(method, Members);
        if (m == null) throw new MissingMethodException(target.GetType().Name, method);
        m.Invoke(target, null);
    }

    /// <summary>A serialized field set as the inspector sets it.</summary>
    public static void SetField(object target, string name, object value)
    {
        FieldInfo f = target.GetType().GetField(name, Members);
        if (f == null) throw new MissingFieldException(target.GetType().Name, name);
        f.SetValue(target, value);
    }

    /// <summary>A token or probe argument: "-" stands for an empty one.</summary>
    public static string Text(string arg) { return arg == "-" ? "" : arg; }

    public static float Float(string arg) { return float.Parse(arg, CultureInfo.InvariantCulture); }

    public static double Double(string arg) { return double.Parse(arg, CultureInfo.InvariantCulture); }

    /// <summary>"x,y,z;x,y,z;..." (normals, points) as their components.</summary>
    public static List<float[]> Vectors(string arg)
    {
        var r = new List<float[]>();
        foreach (string t in arg.Split(';'))
        {
            string[] v = t.Split(',');
            r.Add(new[] { Float(v[0]), Float(v[1]), Float(v[2]) });
        }
        return r;
    }

    /// <summary>A JSON number that reads back to the same double ("R"); null for NaN and the infinities.</summary>
    public static string Num(double v)
    {
        return double.IsNaN(v) || double.IsInfinity(v) ? "null" : v.ToString("R", CultureInfo.InvariantCulture);
    }

    public static string Array(IList<double> a)
    {
        var sb = new StringBuilder("[");
        for (int i = 0; i < a.Count; i++) sb.Append(i == 0 ? "" : ",").Append(Num(a[i]));
        return sb.Append(']').ToString();
    }

    /// <summary>A parsed JSON array of numbers (MiniJson's List of doubles).</summary>
    public static double[] Numbers(object o)
    {
        var list = (List<object>)o;
        var r = new double[list.Count];
        for (int i = 0; i < r.Length; i++) r[i] = (double)list[i];
        return r;
    }

    /// <summary>
    /// Play frames until <paramref name="until"/> holds (true) or <paramref name="seconds"/> pass (false): each
    /// frame is <paramref name="frame"/>, then a short wait as a frame takes, so the component's socket is
    /// waited on, never raced.
    /// </summary>
    public static bool Play(Action frame, Func<bool> until, double seconds)
    {
        DateTime end = DateTime.UtcNow.AddSeconds(seconds);
        while (DateTime.UtcNow < end)
        {
            frame();
            if (until()) return true;
            Thread.Sleep(10);
        }
        return false;
    }
}
