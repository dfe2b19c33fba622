// The package's registration core (Sh9Registration, Sh9RegistrationMath) and the lighting path it
// feeds (Sh9Protocol → Sh9Snapshot → Sh9LightingValues, Sh9UnityCubeBaker) under Mono, for
// tests/clients/unity/test_unity_cube.py. No UnityEngine.
//
//   RegistrationTest.exe JOB.json [CUBE.ktx2 OUT.bin]
// JOB: {"message": "<an sh9 message with \"registration\">",
//       "cases": [{"q": [x, y, z, w], "p": [x, y, z], "axes": 0|1}, ...]}   (the marker Transform, Unity world)
// Prints one JSON line per case: {"rotation": [9], "quaternion": [4], "camera": [3], "matrices": [48],
// "alloc_bytes": managed bytes of the composition and the conversion on a repeat}, or {"error": ...} and
// exit 2 when the message is refused. With CUBE.ktx2, the first case's rotation bakes the cube into OUT.bin.
using System;
using System.Collections.Generic;
using System.IO;
using System.Text;
using Shlight.Lighting;

static class RegistrationTest
{
    static string Numbers(double[] v)
    {
        var sb = new StringBuilder("[");
        for (int i = 0; i < v.Length; i++) sb.Append(i > 0 ? "," : "").Append(MiniJson.Number(v[i]));
        return sb.Append(']').ToString();
    }

    static double[] Array(object raw)
    {
        var list = (List<object>)raw;
        var v = new double[list.Count];
        for (int i = 0; i < v.Length; i++) v[i] = (double)list[i];
        return v;
    }

    static int Main(string[] args)
    {
        Dictionary<string, object> job = MiniJson.ParseObject(File.ReadAllText(args[0]));
        Sh9Parsed parsed;
        try
        {
            parsed = Sh9Protocol.Parse((string)job["message"]);
        }
        catch (FormatException e)
        {
            Console.WriteLine("{\"error\":" + MiniJson.Quote(e.Message) + "}");
            return 2;
        }
        var snapshot = new Sh9Snapshot(parsed.Sh9, 0, 1);
        Sh9Registration reg = parsed.Sh9.Registration;
        var values = new Sh9LightingValues();
        double[] rotation = new double[9], q = new double[4], camera = new double[3], scratch = new double[27];
        double[] centre = new double[3];
        bool first = true;
        foreach (object c in (List<object>)job["cases"])
        {
            var cs = (Dictionary<string, object>)c;
            double[] mq = Array(cs["q"]), mp = Array(cs["p"]);
            var axes = (Sh9MarkerAxes)(int)(double)cs["axes"];
            object sideRaw;
            double side = cs.TryGetValue("side", out sideRaw) ? (double)sideRaw : 0.0;
            long allocated = 0;
            for (int pass = 0; pass < 2; pass++)        // the second pass is measured
            {
                long before = GC.GetAllocatedBytesForCurrentThread();
                Sh9RegistrationMath.MarkerCentre(mq[0], mq[1], mq[2], mq[3], mp, axes, side, centre);
                Sh9RegistrationMath.ProbeRotation(mq[0], mq[1], mq[2], mq[3], centre, axes, reg.Rotation, reg.Position,
                                                  rotation, q, camera, scratch);
                values.Set(snapshot, q[0], q[1], q[2], q[3], 1.0, false);
                allocated = GC.GetAllocatedBytesForCurrentThread() - before;
            }
            var m = new double[48];
            for (int i = 0; i < 48; i++) m[i] = values.Matrices[i];
            Console.WriteLine("{\"rotation\":" + Numbers(rotation) + ",\"quaternion\":" + Numbers(q) + ",\"camera\":" +
                              Numbers(camera) + ",\"matrices\":" + Numbers(m) + ",\"alloc_bytes\":" + allocated + "}");
            if (first && args.Length >= 3)
            {
                byte[] file = File.ReadAllBytes(args[1]);
                var baker = new Sh9UnityCubeBaker();
                baker.Bake(Sh9Ktx2.Parse(file, 0, file.Length), rotation);
                var bytes = new byte[baker.Data.Length * 2];
                Buffer.BlockCopy(baker.Data, 0, bytes, 0, bytes.Length);
                File.WriteAllBytes(args[2], bytes);
            }
            first = false;
        }
        return 0;
    }
}
