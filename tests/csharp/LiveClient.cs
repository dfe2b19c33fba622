// A Mono program built from the package's code (Runtime/Core + the SH9LightingClient
// MonoBehaviour) and tests/unity_stubs/UnityEngineStandIn.cs -- a compile-only stand-in for
// UnityEngine, NOT Unity. tests/clients/unity/test_unity.py runs it against a live `shlight serve`.
//
// It plays the part of Unity's player loop: calls the component's OnEnable, then Update every
// 20 ms, and prints one JSON line per event on stdout:
//   {"event":"state","state":"Live",...}                      when SH9LightingClient.State changes
//   {"event":"applied","seq":..,"stale":..,"matrices":[48],"ambient":[27],"wire_matrices":[48],...}
//                                                            when a new message has been applied
// The "matrices" are what Update passed to Shader.SetGlobalMatrix (_SHIrradianceR/G/B) and
// "ambient" what it assigned to RenderSettings.ambientProbe, read back from the stand-in; with
// --light, "light" is the driven Directional Light as the stand-in holds it (--shadows: the component's
// KeyLightShadows on: the key light drawn, its shadows set, sh9_lights.hlsl's globals reported).
// Stdin: "quit" ends the program (exit 0), and so does the end of stdin (the test runner went
// away); it also ends after the time limit in args. "pause" plays a suspended app (Unity calls
// OnApplicationPause(true) and OnApplicationFocus(false), then no Update until the app is back);
// "resume" plays its return (OnApplicationPause(false), OnApplicationFocus(true), Update again);
// "blur" / "focus" play OnApplicationFocus(false) / (true) alone, with Update going on.
// The component's log (Debug.Log of the stand-in) goes to stderr.
//
// Allocations: every Update is bracketed by GC.GetAllocatedBytesForCurrentThread (the main
// thread's managed allocations, Mono's exact per-thread counter). Frames in which the component
// logged something (a state change, a connection event) are event frames; all others, after
// warm-up (the first 3 applied messages), are steady frames, and the exit event reports their
// count, how many of them applied a new message, and the bytes they allocated.
//
// usage: LiveClient.exe URL TOKEN PROBE SECONDS [QX QY QZ QW] [--token-in-query] [--intensity=X]
//        [--light] [--shadows] [--color-space=linear|gamma] [--linear-intensity]
//        [--exposure=relative|camera_image|physical_camera] [--exposure-compensation=EV] [--color-temperature]
//        [--physical-camera=APERTURE,ISO]
//   (issue 31: the component's Exposure Mode, Exposure Compensation and Use Color Temperature; "light_seen"
//   is the linear colour the shaders get from the light, its colour temperature included)
//   TOKEN or PROBE "-": empty. QX..QW: the rotation of the component's transform.
using System;
using System.Globalization;
using System.Reflection;
using System.Text;
using System.Threading;
using Shlight.Lighting;
using UnityEngine;
using UnityEngine.Rendering;

static class LiveClient
{
    static readonly object outLock = new object();

    static void Emit(string json)
    {
        lock (outLock)
        {
            Console.Out.WriteLine(json);
            Console.Out.Flush();
        }
    }

    // Unity's messages and the inspector's fields by reflection: Harness.cs (shared with the other drivers);
    // only the messages that take a flag (OnApplicationPause/Focus) are called here.
    static void Call(object target, string method, bool argument)
    {
        MethodInfo m = target.GetType().GetMethod(method, BindingFlags.Instance | BindingFlags.NonPublic | BindingFlags.Public);
        m.Invoke(target, new object[] { argument });
    }

    // A delegate, not MethodInfo.Invoke: reflection would allocate in the frames being measured.
    static Action Method(object target, string method)
    {
        MethodInfo m = target.GetType().GetMethod(method, BindingFlags.Instance | BindingFlags.NonPublic | BindingFlags.Public);
        return (Action)m.CreateDelegate(typeof(Action), target);
    }

    static string NumberOrNull(double v)
    {
        return double.IsNaN(v) || double.IsInfinity(v) ? "null" : MiniJson.Number(v);
    }

    // What Unity's shaders get from the light, linear (GraphicsSettings.lightsUseLinearIntensity on:
    // color.linear × intensity, × the temperature's linear RGB when the light uses one).
    static double[] LightSeen(Light light)
    {
        Color c = light.color.linear;
        Color k = light.useColorTemperature && UnityEngine.Rendering.GraphicsSettings.lightsUseColorTemperature
            ? Mathf.CorrelatedColorTemperatureToRGB(light.colorTemperature) : Color.white;
        return new double[] { c.r * k.r * light.intensity, c.g * k.g * light.intensity, c.b * k.b * light.intensity };
    }

    static string LightJson(Light light)
    {
        if (light == null) return "null";
        Vector3 f = light.transform.forward;   // the stand-in's rotation * Vector3.forward
        Color c = light.color;
        return "{\"enabled\":" + (light.enabled ? "true" : "false") +
               ",\"forward\":" + Array(new double[] { f.x, f.y, f.z }) +
               ",\"color\":" + Array(new double[] { c.r, c.g, c.b }) +
               ",\"intensity\":" + MiniJson.Number(light.intensity) +
               ",\"use_color_temperature\":" + (light.useColorTemperature ? "true" : "false") +
               ",\"color_temperature\":" + NumberOrNull(light.colorTemperature) +
               ",\"light_seen\":" + Array(LightSeen(light)) +
               ",\"shadows\":\"" + light.shadows + "\",\"shadow_strength\":" + MiniJson.Number(light.shadowStrength) + "}";
    }

    static string Array(float[] v)
    {
        return Array(System.Array.ConvertAll(v, x => (double)x));  // MiniJson.Number takes double
    }

    static string Array(double[] v)
    {
        var sb = new StringBuilder("[");
        for (int i = 0; i < v.Length; i++)
        {
            if (i > 0) sb.Append(',');
            sb.Append(MiniJson.Number(v[i]));
        }
        return sb.Append(']').ToString();
    }

    static float[] GlobalMatrices()
    {
        var result = new float[48];
        string[] names = { "_SHIrradianceR", "_SHIrradianceG", "_SHIrradianceB" };
        for (int c = 0; c < 3; c++)
        {
            Matrix4x4 m = Shader.StandInGlobalMatrices[Shader.PropertyToID(names[c])];
            for (int r = 0; r < 4; r++)
                for (int k = 0; k < 4; k++) result[16 * c + 4 * r + k] = m[r, k];
        }
        return result;
    }

    static float GlobalFloat(string name)
    {
        float v;
        return Shader.StandInGlobalFloats.TryGetValue(Shader.PropertyToID(name), out v) ? v : float.NaN;
    }

    static int GlobalInt(string name)
    {
        int v;
        return Shader.StandInGlobalInts.TryGetValue(Shader.PropertyToID(name), out v) ? v : -1;
    }

    // the first vector of a global vector array (sh9_lights.hlsl's light 0), or null
    static string GlobalVector0(string name)
    {
        Vector4[] v;
        if (!Shader.StandInGlobalVectorArrays.TryGetValue(Shader.PropertyToID(name), out v)) return "null";
        return Array(new double[] { v[0].x, v[0].y, v[0].z, v[0].w });
    }

    // a global vector (sh9_lights.hlsl's _SHLightAngularRadius), or null
    static string GlobalVector(string name)
    {
        Vector4 v;
        if (!Shader.StandInGlobalVectors.TryGetValue(Shader.PropertyToID(name), out v)) return "null";
        return Array(new double[] { v.x, v.y, v.z, v.w });
    }

    static float[] AmbientProbe()
    {
        var result = new float[27];
        SphericalHarmonicsL2 sh = RenderSettings.ambientProbe;
        for (int c = 0; c < 3; c++)
            for (int i = 0; i < 9; i++) result[9 * c + i] = sh[c, i];
        return result;
    }

    static int Main(string[] args)
    {
        CultureInfo.DefaultThreadCurrentCulture = CultureInfo.InvariantCulture;
        Thread.CurrentThread.CurrentCulture = CultureInfo.InvariantCulture;
        var flags = new System.Collections.Generic.List<string>();
        var positional = new System.Collections.Generic.List<string>();
        foreach (string a in args) (a.StartsWith("--") ? flags : positional).Add(a);
        args = positional.ToArray();
        string url = args[0], token = args[1] == "-" ? "" : args[1], probe = args[2] == "-" ? "" : args[2];
        double seconds = double.Parse(args[3], CultureInfo.InvariantCulture);

        var component = new SH9LightingClient();
        Light light = null;
        Camera camera = null;
        foreach (string f in flags)
        {
            if (f == "--token-in-query") Harness.SetField(component, "tokenInQuery", true);
            else if (f.StartsWith("--intensity=")) component.Intensity = float.Parse(f.Substring(12), CultureInfo.InvariantCulture);
            else if (f == "--light")
            {
                light = new GameObject("Sun").AddComponent<Light>();
                light.type = LightType.Directional;
                light.color = new Color(1f, 0.95f, 0.8f);   // the scene's own values, restored on disable
                light.intensity = 1.25f;
                component.DirectionalLight = light;
            }
            else if (f == "--shadows") component.KeyLightShadows = true;
            else if (f == "--color-space=gamma") QualitySettings.StandInColorSpace = ColorSpace.Gamma;
            else if (f == "--color-space=linear") QualitySettings.StandInColorSpace = ColorSpace.Linear;
            else if (f == "--linear-intensity") UnityEngine.Rendering.GraphicsSettings.lightsUseLinearIntensity = true;
            else if (f == "--exposure=camera_image") component.ExposureMode = Sh9ExposureMode.CameraImage;
            else if (f == "--exposure=physical_camera") component.ExposureMode = Sh9ExposureMode.PhysicalCamera;
            else if (f == "--exposure=relative") component.ExposureMode = Sh9ExposureMode.Relative;
            else if (f.StartsWith("--exposure-compensation="))
                component.ExposureCompensation = float.Parse(f.Substring(24), CultureInfo.InvariantCulture);
            else if (f == "--color-temperature") component.UseColorTemperature = true;
            else if (f.StartsWith("--physical-camera="))
            {
                string[] ni = f.Substring(18).Split(',');
                camera = new GameObject("Camera").AddComponent<Camera>();
                camera.aperture = float.Parse(ni[0], CultureInfo.InvariantCulture);
                camera.iso = int.Parse(ni[1], CultureInfo.InvariantCulture);
                component.PhysicalCamera = camera;
            }
            else throw new ArgumentException("unknown option " + f);
        }
        if (args.Length >= 8)
        {
            component.transform.rotation = new Quaternion(
                float.Parse(args[4], CultureInfo.InvariantCulture), float.Parse(args[5], CultureInfo.InvariantCulture),
                float.Parse(args[6], CultureInfo.InvariantCulture), float.Parse(args[7], CultureInfo.InvariantCulture));
        }
        component.ServerUrl = url;
        component.Token = token;
        component.Probe = probe;
        component.DriveAmbientProbe = true;
        Harness.SetField(component, "staleAfterSeconds", 30f);  // staleness here must come from the server
        Harness.SetField(component, "logToConsole", true);   // to stderr (the stand-in's Debug.Log)

        bool quit = false;
        var commands = new System.Collections.Concurrent.ConcurrentQueue<string>();
        var stdin = new Thread(() =>
        {
            string line;
            while ((line = Console.In.ReadLine()) != null)
            {
                if (line.Trim() == "quit") break;
                commands.Enqueue(line.Trim());
            }
            quit = true;
        });
        stdin.IsBackground = true;
        stdin.Start();

        Harness.Call(component, "OnEnable");
        Action update = Method(component, "Update");
        bool paused = false;
        int appliedSeen = 0;
        long steadyFrames = 0, steadyApplied = 0, steadyBytes = 0, eventFrames = 0, worstSteadyFrame = 0;
        Sh9Message beforeUpdate = null;
        Sh9ConnectionState lastState = (Sh9ConnectionState)(-1);
        long lastApplied = -1;
        bool lastStale = false;
        int lastConnections = 0;
        double lastPrint = -1;
        var clock = System.Diagnostics.Stopwatch.StartNew();
        try
        {
            while (!quit && clock.Elapsed.TotalSeconds < seconds)
            {
                string command;
                while (commands.TryDequeue(out command))
                {
                    if (command == "pause" && !paused)
                    {
                        Call(component, "OnApplicationPause", true);
                        Call(component, "OnApplicationFocus", false);
                        paused = true;
                        Emit("{\"event\":\"paused\",\"t\":" + MiniJson.Number(clock.Elapsed.TotalSeconds) + "}");
                    }
                    else if (command == "blur")
                    {
                        Call(component, "OnApplicationFocus", false);   // e.g. a system menu opened; Update goes on
                        Emit("{\"event\":\"blurred\",\"t\":" + MiniJson.Number(clock.Elapsed.TotalSeconds) + "}");
                    }
                    else if (command == "focus")
                    {
                        Emit("{\"event\":\"focused\",\"t\":" + MiniJson.Number(clock.Elapsed.TotalSeconds) +
                             ",\"connections\":" + component.Connections + "}");
                        Call(component, "OnApplicationFocus", true);
                    }
                    else if (command == "resume" && paused)
                    {
                        Emit("{\"event\":\"resumed\",\"t\":" + MiniJson.Number(clock.Elapsed.TotalSeconds) +
                             ",\"connections\":" + component.Connections + "}");
                        Call(component, "OnApplicationPause", false);
                        Call(component, "OnApplicationFocus", true);
                        paused = false;
                    }
                }
                if (paused)
                {
                    Thread.Sleep(20);   // a suspended app runs no Update
                    continue;
                }
                beforeUpdate = component.LastMessage;
                int logged = Debug.StandInMessages;
                long allocated = GC.GetAllocatedBytesForCurrentThread();
                update();
                allocated = GC.GetAllocatedBytesForCurrentThread() - allocated;
                bool appliedNow = !ReferenceEquals(component.LastMessage, beforeUpdate);
                if (appliedNow) appliedSeen++;
                if (Debug.StandInMessages != logged) eventFrames++;
                else if (appliedSeen > 3)
                {
                    steadyFrames++;
                    if (appliedNow) steadyApplied++;
                    steadyBytes += allocated;
                    worstSteadyFrame = Math.Max(worstSteadyFrame, allocated);
                }
                if (component.State != lastState)
                {
                    lastState = component.State;
                    Emit("{\"event\":\"state\",\"state\":\"" + lastState + "\",\"t\":" + MiniJson.Number(clock.Elapsed.TotalSeconds) +
                         ",\"connections\":" + component.Connections +
                         ",\"has_lighting\":" + (component.HasLighting ? "true" : "false") +
                         ",\"handshake_status\":" + component.HandshakeStatus +
                         ",\"error\":" + MiniJson.Quote(component.LastError ?? "") + "}");
                }
                Sh9Message msg = component.LastMessage;
                // a new message object means Update applied a new snapshot
                long key = msg == null ? -1 : System.Runtime.CompilerServices.RuntimeHelpers.GetHashCode(msg);
                double now = clock.Elapsed.TotalSeconds;
                // print the first message, every change of stale/connection, and at most 4 per second otherwise
                if (msg != null && key != lastApplied &&
                    (lastPrint < 0 || msg.Stale != lastStale || component.Connections != lastConnections || now - lastPrint > 0.25))
                {
                    lastApplied = key;
                    lastStale = msg.Stale;
                    lastConnections = component.Connections;
                    lastPrint = now;
                    Sh9Hello hello = component.ServerHello;
                    Emit("{\"event\":\"applied\",\"seq\":" + msg.Seq + ",\"stale\":" + (msg.Stale ? "true" : "false") +
                         ",\"probe\":" + MiniJson.Quote(msg.Probe) + ",\"state\":\"" + component.State + "\"" +
                         ",\"connections\":" + component.Connections +
                         ",\"has_lighting\":" + (component.HasLighting ? "true" : "false") +
                         ",\"last_seq\":" + component.LastSeq +
                         ",\"age_s\":" + MiniJson.Number(component.AgeSeconds) +
                         ",\"wire_age_s\":" + MiniJson.Number(msg.AgeSeconds) +
                         ",\"hello_probes\":" + (hello == null ? 0 : hello.Probes.Length) +
                         ",\"matrices\":" + Array(GlobalMatrices()) + ",\"ambient\":" + Array(AmbientProbe()) +
                         ",\"wire_matrices\":" + Array(msg.Matrices) + ",\"wire_coefficients\":" + Array(msg.Coefficients) +
                         ",\"ambient_mode\":\"" + RenderSettings.ambientMode + "\"" +
                         ",\"lights\":" + msg.Lights + ",\"light_active\":" + (component.LightActive ? "true" : "false") +
                         ",\"light\":" + LightJson(light) +
                         ",\"wire_units\":" + MiniJson.Quote(msg.CoefficientUnits) +
                         ",\"wire_ev100\":" + NumberOrNull(msg.Ev100) +
                         ",\"wire_cct_k\":" + NumberOrNull(msg.CctK) +
                         ",\"wire_light_cct_k\":" + Array(msg.LightCctK) +
                         ",\"wire_light_illuminance_lux\":" + Array(msg.LightIlluminanceLux) +
                         ",\"exposure_scale\":" + NumberOrNull(component.AppliedExposure.Scale) +
                         ",\"camera_ev100\":" + NumberOrNull(component.CameraEv100) +
                         ",\"light_color_temperature_k\":" + NumberOrNull(component.LightColorTemperatureK) +
                         ",\"camera\":" + (camera == null ? "null" : "{\"aperture\":" + MiniJson.Number(camera.aperture) +
                                             ",\"iso\":" + camera.iso + ",\"shutter_speed\":" +
                                             MiniJson.Number(camera.shutterSpeed) + "}") +
                         ",\"lights_use_color_temperature\":" +
                         (UnityEngine.Rendering.GraphicsSettings.lightsUseColorTemperature ? "true" : "false") +
                         ",\"main_light_scale\":" + MiniJson.Number(GlobalFloat("_SHMainLightScale")) +
                         ",\"wire_light_directions\":" + Array(msg.LightDirections) +
                         ",\"wire_light_irradiance\":" + Array(msg.LightIrradiance) +
                         ",\"wire_light_angular_radius_deg\":" + Array(msg.LightAngularRadiusDeg) +
                         ",\"light_angular_radius_deg\":" + MiniJson.Number(component.LightAngularRadiusDeg) +
                         ",\"sh_light_count\":" + GlobalInt("_SHLightCount") +
                         ",\"sh_light_direction\":" + GlobalVector0("_SHLightDirection") +
                         ",\"sh_light_irradiance\":" + GlobalVector0("_SHLightIrradiance") +
                         ",\"sh_light_angular_radius\":" + GlobalVector("_SHLightAngularRadius") +
                         ",\"wire_ambient_coefficients\":" + (msg.AmbientCoefficients == null ? "null" : Array(msg.AmbientCoefficients)) +
                         "}");
                }
                Thread.Sleep(20);
            }
        }
        finally
        {
            long received = component.MessagesReceived;
            Harness.Call(component, "OnDisable");
            Emit("{\"event\":\"exit\",\"state\":\"" + component.State + "\",\"received\":" + received +
                 ",\"connections\":" + component.Connections +
                 ",\"ambient_mode_restored\":\"" + RenderSettings.ambientMode + "\"" +
                 ",\"light_restored\":" + LightJson(light) +
                 ",\"steady_frames\":" + steadyFrames + ",\"steady_applied_frames\":" + steadyApplied +
                 ",\"steady_alloc_bytes\":" + steadyBytes + ",\"worst_steady_frame_bytes\":" + worstSteadyFrame +
                 ",\"event_frames\":" + eventFrames + "}");
        }
        // Everything is said and the component is stopped. Mono's own runtime shutdown can
        // deadlock on thread-pool threads left in socket calls (seen under heavy CPU load, where
        // even a SIGQUIT thread dump hangs), so this harness leaves with _exit rather than risk
        // a hung test run. Unity never exits a player this way; the component's Stop() is bounded.
        Console.Out.Flush();
        Console.Error.Flush();
        try { _exit(0); } catch (Exception) { }
        return 0;
    }

    [System.Runtime.InteropServices.DllImport("libc")]
    static extern void _exit(int status);
}
