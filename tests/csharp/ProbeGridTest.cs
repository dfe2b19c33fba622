// Drives SH9ProbeGrid (the package's MonoBehaviour) against a live `shlight serve` through Unity's player
// loop as tests/unity_stubs/UnityEngineStandIn.cs plays it (NOT Unity): the scene's LightProbes are filled
// from /probe-grid.json, refilled at the refresh rate, re-tetrahedralised only when the points move.
// First with no LightProbes in the scene (the component says to bake a Light Probe Group), then with one.
// Arguments: URL TOKEN MINX MINY MINZ MAXX MAXY MAXZ STEP ATX ATY ATZ (Unity's frame) [NORMALS (x,y,z;...)].
// Prints one JSON object: the probes' positions and values after the first fill, the probe at AT evaluated
// at NORMALS (Unity's frame) with SphericalHarmonicsL2.Evaluate, and the counts of the phases. Built with Harness.cs.
using System;
using System.Collections.Generic;
using System.Text;
using Shlight.Lighting;
using UnityEngine;
using UnityEngine.Rendering;

static class ProbeGridTest
{
    // Unity's player loop: Update, then the next frame
    static bool Play(SH9ProbeGrid grid, Func<bool> until, double seconds)
    {
        return Harness.Play(() => { Harness.Call(grid, "Update"); Time.StandInFrameCount++; }, until, seconds);
    }

    static int Main(string[] a)
    {
        var probes = LightProbes.StandInCreate();
        LightmapSettings.lightProbes = null;       // first a scene without baked light probes
        var go = new GameObject("grid");
        var grid = go.AddComponent<SH9ProbeGrid>();
        grid.ServerUrl = a[0];
        grid.Token = a[1];
        grid.BoxMin = new Vector3(Harness.Float(a[2]), Harness.Float(a[3]), Harness.Float(a[4]));
        grid.BoxMax = new Vector3(Harness.Float(a[5]), Harness.Float(a[6]), Harness.Float(a[7]));
        grid.Step = Harness.Float(a[8]);
        grid.RefreshSeconds = 0.2f;
        var at = new Vector3(Harness.Float(a[9]), Harness.Float(a[10]), Harness.Float(a[11]));
        var normals = new List<Vector3>();
        if (a.Length > 12)
            foreach (float[] v in Harness.Vectors(a[12])) normals.Add(new Vector3(v[0], v[1], v[2]));
        var o = new StringBuilder("{");
        Harness.Call(grid, "OnEnable");
        Play(grid, () => grid.LastError != null && grid.LastError.Contains("Light Probe Group"), 90);
        o.Append("\"no_probes_error\":" + MiniJson.Quote(grid.LastError ?? "") + ",\"fills_without_probes\":" + grid.Fills + ",");
        LightmapSettings.lightProbes = probes;
        // the server may not have every probe's frame yet: 503s until it has
        bool first = Play(grid, () => grid.Fills >= 1, 90);
        o.Append("\"first\":" + (first ? "true" : "false") + ",\"error\":" + MiniJson.Quote(grid.LastError ?? ""));
        if (first)
        {
            o.Append(",\"positions\":[");
            Vector3[] ps = probes.positions;
            for (int i = 0; i < ps.Length; i++)
                o.Append((i > 0 ? "," : "") + Harness.Num(ps[i].x) + "," + Harness.Num(ps[i].y) + "," + Harness.Num(ps[i].z));
            o.Append("],\"probes\":[");
            SphericalHarmonicsL2[] sh = probes.bakedProbes;
            for (int i = 0; i < sh.Length; i++)
                for (int c = 0; c < 3; c++)
                    for (int k = 0; k < 9; k++)
                        o.Append((i + c + k > 0 ? "," : "") + Harness.Num(sh[i][c, k]));
            o.Append("]");
            SphericalHarmonicsL2 here;
            LightProbes.GetInterpolatedProbe(at, null, out here);
            var colors = new Color[normals.Count];
            here.Evaluate(normals.ToArray(), colors);
            o.Append(",\"evaluated\":[");
            for (int i = 0; i < colors.Length; i++)
                o.Append((i > 0 ? "," : "") + Harness.Num(colors[i].r) + "," + Harness.Num(colors[i].g) + "," + Harness.Num(colors[i].b));
            o.Append("]");
            // refreshed at the rate: the same points, new values, no re-tetrahedralisation
            bool refreshed = Play(grid, () => grid.Fills >= 3, 60);
            o.Append(",\"refreshed\":" + (refreshed ? "true" : "false") + ",\"tetrahedralizations_after_refresh\":" + grid.Tetrahedralizations);
            // a finer step moves the points: Unity's tetrahedra are rebuilt once (a fetch already under way when
            // the step changed may bring the old points first: that fill is no move)
            grid.Step = grid.Step / 2;
            int before = grid.Tetrahedralizations;
            bool moved = Play(grid, () => grid.Tetrahedralizations > before, 90);
            o.Append(",\"moved\":" + (moved ? "true" : "false") + ",\"count_after_move\":" + probes.count +
                     ",\"tetrahedralizations_after_move\":" + grid.Tetrahedralizations +
                     ",\"stand_in_tetrahedralize_calls\":" + LightProbes.StandInTetrahedralizeCalls);
        }
        // a wrong token: the fill stops with the server's refusal, the probes stay as they were
        grid.Token = "wrong";
        int fills = grid.Fills;
        Play(grid, () => grid.LastError != null && grid.LastError.Contains("401"), 30);
        o.Append(",\"wrong_token_error\":" + MiniJson.Quote(grid.LastError ?? "") + ",\"fills_with_wrong_token\":" + (grid.Fills - fills));
        o.Append("}");
        Console.WriteLine(o.ToString());
        return 0;
    }
}
