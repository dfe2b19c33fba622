// The package's reflection-cube core (Runtime/Core: Sh9Ktx2, Sh9UnityCubeBaker) under Mono, for
// tests/clients/unity/test_unity_cube.py. No UnityEngine, no stand-in.
//
//   CubeTest.exe bake CUBE.ktx2 OUT.bin [R00 R01 ... R22]
//       parses the provider's KTX2, bakes the Unity cube for the probe rotation R (Unity frame,
//       row-major; identity when absent), writes Sh9UnityCubeBaker.Data (little-endian halves) to
//       OUT.bin and prints one JSON line: sizes, offsets, Unity level roughness, bake times and the
//       managed bytes a second bake of the same cube allocated (GC.GetAllocatedBytesForCurrentThread).
//   CubeTest.exe halves IN.f32 OUT.u16   float32 → half (Sh9Ktx2.FloatToHalf), and back in OUT.f32
//   On a file the reader refuses: {"error": "..."} and exit status 2.
using System;
using System.Diagnostics;
using System.Globalization;
using System.IO;
using System.Text;
using Shlight.Lighting;

static class CubeTest
{
    static string Numbers(double[] v)
    {
        var sb = new StringBuilder("[");
        for (int i = 0; i < v.Length; i++) sb.Append(i > 0 ? "," : "").Append(MiniJson.Number(v[i]));
        return sb.Append(']').ToString();
    }

    static int Main(string[] args)
    {
        if (args[0] == "halves")
        {
            byte[] raw = File.ReadAllBytes(args[1]);
            var halves = new byte[raw.Length / 2];
            var back = new byte[raw.Length];
            for (int i = 0; i < raw.Length / 4; i++)
            {
                ushort h = Sh9Ktx2.FloatToHalf(BitConverter.ToSingle(raw, 4 * i));
                halves[2 * i] = (byte)h; halves[2 * i + 1] = (byte)(h >> 8);
                Array.Copy(BitConverter.GetBytes(Sh9Ktx2.HalfToFloat(h)), 0, back, 4 * i, 4);
            }
            File.WriteAllBytes(args[2], halves);
            File.WriteAllBytes(Path.ChangeExtension(args[2], ".f32"), back);
            return 0;
        }
        byte[] file = File.ReadAllBytes(args[1]);
        Sh9EnvironmentCube cube;
        try
        {
            cube = Sh9Ktx2.Parse(file, 0, file.Length);
        }
        catch (FormatException e)
        {
            Console.WriteLine("{\"error\":" + MiniJson.Quote(e.Message) + "}");
            return 2;
        }
        double[] rotation = null;
        if (args.Length >= 12)
        {
            rotation = new double[9];
            for (int i = 0; i < 9; i++) rotation[i] = double.Parse(args[3 + i], CultureInfo.InvariantCulture);
        }
        var baker = new Sh9UnityCubeBaker();
        var watch = Stopwatch.StartNew();
        baker.Bake(cube, rotation);
        double firstMs = watch.Elapsed.TotalMilliseconds;
        long before = GC.GetAllocatedBytesForCurrentThread();
        watch.Restart();
        baker.Bake(cube, rotation);
        double againMs = watch.Elapsed.TotalMilliseconds;
        long allocated = GC.GetAllocatedBytesForCurrentThread() - before;
        var bytes = new byte[baker.Data.Length * 2];
        Buffer.BlockCopy(baker.Data, 0, bytes, 0, bytes.Length);
        File.WriteAllBytes(args[2], bytes);
        var offsets = new double[Sh9UnityCubeBaker.Levels];
        var levelRoughness = new double[Sh9UnityCubeBaker.Levels];
        var levelMip = new double[Sh9UnityCubeBaker.Levels];
        for (int m = 0; m < Sh9UnityCubeBaker.Levels; m++)
        {
            offsets[m] = baker.Offset(m, 0);
            levelRoughness[m] = Sh9UnityCubeBaker.UnityLevelRoughness(m);
            levelMip[m] = Sh9UnityCubeBaker.UnityMipForRoughness(levelRoughness[m]);
        }
        Console.WriteLine("{\"provider_size\":" + cube.Size + ",\"mips\":" + cube.MipCount + ",\"seq\":" + cube.Seq +
                          ",\"sh9_seq\":" + cube.Sh9Seq + ",\"roughness\":" + Numbers(cube.Roughness) +
                          ",\"size\":" + baker.Size + ",\"levels\":" + Sh9UnityCubeBaker.Levels +
                          ",\"offsets\":" + Numbers(offsets) + ",\"level_roughness\":" + Numbers(levelRoughness) +
                          ",\"level_mip\":" + Numbers(levelMip) + ",\"halves\":" + baker.Data.Length +
                          ",\"bake_ms\":" + MiniJson.Number(firstMs) + ",\"rebake_ms\":" + MiniJson.Number(againMs) +
                          ",\"rebake_alloc_bytes\":" + allocated + "}");
        return 0;
    }
}
