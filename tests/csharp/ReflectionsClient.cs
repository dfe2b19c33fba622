// A Mono program built from the package's code (Runtime/Core, SH9LightingClient, SH9Reflections,
// SH9MarkerRegistration) and tests/unity_stubs/UnityEngineStandIn.cs -- a compile-only stand-in for
// UnityEngine, NOT Unity. tests/clients/unity/test_unity_cube.py runs it against `shlight serve --environment`.
//
// It plays Unity's player loop for SECONDS: OnEnable, then every 20 ms the components' Update in
// their execution order (SH9MarkerRegistration at -100 first), each frame bracketed by
// GC.GetAllocatedBytesForCurrentThread. Frames in which something was logged or the Cubemap object
// was (re)created are event frames; the others after the first upload are steady frames. At the end
// it writes the Cubemap's texels (all levels and faces, RGBA halves) to OUT.bin and prints one JSON line.
//
// usage: ReflectionsClient.exe URL SECONDS OUT.bin [--probe] [--registration=R00,...,R22,PX,PY,PZ]
using System;
using System.Globalization;
using System.IO;
using System.Reflection;
using System.Threading;
using Shlight.Lighting;
using UnityEngine;
using UnityEngine.Rendering;

static class ReflectionsClient
{
    static Action Method(object target, string name)
    {
        MethodInfo m = target.GetType().GetMethod(name, BindingFlags.Instance | BindingFlags.NonPublic | BindingFlags.Public);
        return (Action)m.CreateDelegate(typeof(Action), target);
    }

    static int Main(string[] args)
    {
        CultureInfo.DefaultThreadCurrentCulture = CultureInfo.InvariantCulture;
        string url = args[0];
        double seconds = double.Parse(args[1], CultureInfo.InvariantCulture);
        var go = new GameObject("Room light");
        var lighting = go.AddComponent<SH9LightingClient>();
        lighting.ServerUrl = url;
        lighting.Token = "";
        var reflections = go.AddComponent<SH9Reflections>();
        ReflectionProbe probe = null;
        SH9MarkerRegistration registration = null;
        foreach (string a in args)
        {
            if (a == "--probe")
            {
                probe = new GameObject("Probe").AddComponent<ReflectionProbe>();
                reflections.ReflectionProbe = probe;
            }
            else if (a.StartsWith("--registration="))
            {
                string[] v = a.Substring(15).Split(',');
                var reg = new Sh9Registration { Rotation = new double[9], Position = new double[3], MarkerId = "7" };
                for (int i = 0; i < 9; i++) reg.Rotation[i] = double.Parse(v[i], CultureInfo.InvariantCulture);
                for (int i = 0; i < 3; i++) reg.Position[i] = double.Parse(v[9 + i], CultureInfo.InvariantCulture);
                var marker = new GameObject("Marker").transform;
                marker.rotation = new Quaternion(0.2f, -0.4f, 0.1f, 0.888819f);
                marker.position = new Vector3(1f, 1.5f, 2f);
                registration = go.AddComponent<SH9MarkerRegistration>();
                registration.LightingClient = lighting;
                registration.Marker = marker;
                registration.UseRegistration(reg);
            }
        }
        Method(lighting, "OnEnable")();
        Method(reflections, "OnEnable")();
        Action updateRegistration = registration == null ? null : Method(registration, "Update");
        Action updateLighting = Method(lighting, "Update"), updateReflections = Method(reflections, "Update");
        long steadyFrames = 0, steadyBytes = 0, eventFrames = 0, uploadFrames = 0, worst = 0;
        Cubemap lastCube = null;
        var clock = System.Diagnostics.Stopwatch.StartNew();
        while (clock.Elapsed.TotalSeconds < seconds)
        {
            int logged = Debug.StandInMessages;
            long uploads = reflections.Uploads;
            long before = GC.GetAllocatedBytesForCurrentThread();
            if (updateRegistration != null) updateRegistration();
            updateLighting();
            updateReflections();
            long bytes = GC.GetAllocatedBytesForCurrentThread() - before;
            bool created = !ReferenceEquals(reflections.Cubemap, lastCube);
            lastCube = reflections.Cubemap;
            if (Debug.StandInMessages != logged || created) eventFrames++;
            else if (reflections.Uploads > 0)
            {
                steadyFrames++;
                steadyBytes += bytes;
                worst = Math.Max(worst, bytes);
                if (reflections.Uploads != uploads) uploadFrames++;
            }
            Thread.Sleep(20);
        }
        Cubemap cube = reflections.Cubemap;
        bool assigned = probe != null ? probe.customBakedTexture == cube && probe.mode == ReflectionProbeMode.Custom
                                      : RenderSettings.customReflection == cube &&
                                        RenderSettings.defaultReflectionMode == DefaultReflectionMode.Custom;
        int size = cube == null ? 0 : cube.width;
        if (cube != null)
        {
            using (var f = File.Create(args[2]))
                for (int m = 0; m < cube.mipmapCount; m++)
                    for (int face = 0; face < 6; face++)
                    {
                        ushort[] t = cube.StandInTexels(m, (CubemapFace)face);
                        var b = new byte[t.Length * 2];
                        Buffer.BlockCopy(t, 0, b, 0, b.Length);
                        f.Write(b, 0, b.Length);
                    }
        }
        Quaternion q = lighting.ProbeRotation;
        string format = cube == null ? "none" : cube.format.ToString();
        string filter = cube == null ? "none" : cube.filterMode.ToString();
        long environments = lighting.LatestEnvironmentCount();
        int mips = cube == null ? 0 : cube.mipmapCount;
        Method(reflections, "OnDisable")();
        Method(lighting, "OnDisable")();
        bool restored = probe != null ? probe.mode == ReflectionProbeMode.Baked && probe.customBakedTexture == null
                                      : RenderSettings.defaultReflectionMode == DefaultReflectionMode.Skybox &&
                                        RenderSettings.customReflection == null;
        Console.WriteLine("{\"size\":" + size + ",\"mips\":" + mips +
                          ",\"format\":\"" + format + "\",\"filter\":\"" + filter + "\",\"uploads\":" + reflections.Uploads +
                          ",\"shown_seq\":" + reflections.ShownSeq + ",\"assigned\":" + (assigned ? "true" : "false") +
                          ",\"restored\":" + (restored ? "true" : "false") +
                          ",\"steady_frames\":" + steadyFrames + ",\"steady_alloc_bytes\":" + steadyBytes +
                          ",\"worst_steady_frame_bytes\":" + worst + ",\"upload_frames\":" + uploadFrames +
                          ",\"event_frames\":" + eventFrames + ",\"environments\":" + environments +
                          ",\"probe_rotation\":[" + q.x + "," + q.y + "," + q.z + "," + q.w + "]}");
        return 0;
    }

    static long LatestEnvironmentCount(this SH9LightingClient c)
    {
        Sh9EnvironmentSnapshot s = c.LatestEnvironment;
        return s == null ? 0 : s.Version;
    }
}
