// Drives SH9PointLight (the package's MonoBehaviour) against a live `shlight serve` through Unity's player
// loop as tests/unity_stubs/UnityEngineStandIn.cs plays it (NOT Unity): a sphere's renderer gets the light
// at its position as its own probe, then the light where it moved to; disabling gives the renderer back.
// Arguments: URL TOKEN ATX ATY ATZ MOVEDX MOVEDY MOVEDZ (Unity's frame) NORMALS (x,y,z;... Unity's frame).
// Prints one JSON object: the renderer's probe evaluated at NORMALS at each place, and what it held.
// Built with Harness.cs.
using System;
using System.Collections.Generic;
using System.Text;
using Shlight.Lighting;
using UnityEngine;
using UnityEngine.Rendering;

static class PointLightTest
{
    // Unity's player loop: Update, then the next frame
    static bool Play(SH9PointLight light, Func<bool> until, double seconds)
    {
        return Harness.Play(() => { Harness.Call(light, "Update"); Time.StandInFrameCount++; }, until, seconds);
    }

    static string Evaluated(Renderer r, Vector3[] normals)
    {
        SphericalHarmonicsL2[] sh = r.StandInPropertyBlock == null ? null : r.StandInPropertyBlock.StandInSH;
        if (sh == null) return "null";
        var colors = new Color[normals.Length];
        sh[0].Evaluate(normals, colors);
        var o = new StringBuilder("[");
        for (int i = 0; i < colors.Length; i++)
            o.Append((i > 0 ? "," : "") + Harness.Num(colors[i].r) + "," + Harness.Num(colors[i].g) + "," + Harness.Num(colors[i].b));
        return o.Append("]").ToString();
    }

    static int Main(string[] a)
    {
        var sphere = GameObject.CreatePrimitive(PrimitiveType.Sphere);
        sphere.transform.position = new Vector3(Harness.Float(a[2]), Harness.Float(a[3]), Harness.Float(a[4]));
        Renderer r = sphere.GetComponent<Renderer>();
        var light = sphere.AddComponent<SH9PointLight>();
        light.ServerUrl = a[0];
        light.Token = a[1];
        var normals = new List<Vector3>();
        foreach (float[] v in Harness.Vectors(a[8])) normals.Add(new Vector3(v[0], v[1], v[2]));
        Harness.Call(light, "OnEnable");
        var o = new StringBuilder("{");
        bool first = Play(light, () => r.StandInPropertyBlock != null && r.StandInPropertyBlock.StandInSH != null, 60);
        o.Append("\"first\":" + (first ? "true" : "false") + ",\"error\":" + MiniJson.Quote(light.Points.LastError ?? ""));
        o.Append(",\"usage\":\"" + r.lightProbeUsage + "\",\"evaluated\":" + Evaluated(r, normals.ToArray()));
        // a small move keeps the subscription; a move past the threshold asks for the light there
        long v0 = light.Points.Version;
        sphere.transform.position = new Vector3(Harness.Float(a[2]) + 0.1f, Harness.Float(a[3]), Harness.Float(a[4]));
        Harness.Call(light, "Update");
        var moved = new Vector3(Harness.Float(a[5]), Harness.Float(a[6]), Harness.Float(a[7]));
        sphere.transform.position = moved;
        bool followed = Play(light, () => light.Points.Position != null && light.Points.Position[0] == moved.x &&
                                         light.Points.Version > v0, 60);
        Play(light, () => false, 0.2);    // the frame after the message: the block is set
        o.Append(",\"followed\":" + (followed ? "true" : "false") + ",\"moved_position\":[" +
                 string.Join(",", Array.ConvertAll(light.Points.Position ?? new double[0], Harness.Num)) + "]");
        o.Append(",\"evaluated_moved\":" + Evaluated(r, normals.ToArray()));
        Harness.Call(light, "OnDisable");
        o.Append(",\"usage_after\":\"" + r.lightProbeUsage + "\",\"block_after\":" +
                 (r.StandInPropertyBlock == null ? "null" : "\"kept\"") + "}");
        Console.WriteLine(o.ToString());
        return 0;
    }
}
