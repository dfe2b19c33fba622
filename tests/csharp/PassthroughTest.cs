// A Mono program built from the package's core (and, for "sender", SH9LightingClient, SH9PassthroughSender and
// the UnityEngine and MRUK stand-ins, -define:SHLIGHT_MRUK) and Harness.cs -- NOT Unity. tests/clients/unity/test_unity_passthrough.py
// runs it.
//
//   lut     stdin: a camera.json object. Out: {"log2_lo", "log2_hi", "toe_scale", "lut": [256 × 4], "display": [...]} with
//           "display" the lookup at the sensor exposures of the second stdin line (a JSON array of [r, g, b]).
//   render  stdin, one JSON per line: a passthrough_camera message, an sh9 message, then per view a passthrough
//           message and {"normals": [[x, y, z], ...] (wire frame), "albedo": A}. Out, per view: {"display":
//           [[r, g, b], ...], "gain", "matrices": [48, Unity frame], "log2_lo", "log2_hi", "toe_scale"}: a grey Lambertian surface of albedo A lit by the SH9 as SH9 Diffuse
//           draws it in Passthrough mode (E(n) = ñᵀMñ in Unity's frame, clamped at 0; ρE/π; × exposure · wb;
//           the display lookup), the maths SH9DiffusePasses.hlsl does, in doubles on the same float lookup.
//   sender  args: URL TOKEN SECONDS; stdin, one JSON per line: {"position": [3], "rotation": [4] (Unity camera
//           pose), "anchor_position", "anchor_rotation", "focal": [2], "principal": [2], "sensor": [2], "size": [2],
//           "time", "jpeg": base64}. Plays Unity's player loop (Update every 10 ms) with SH9LightingClient
//           (Exposure Mode Passthrough) and SH9PassthroughSender on the stand-in PassthroughCameraAccess, one
//           camera image per view, waiting for each view's answer. Out: one {"sent": view message} per view, then
//           {"answers", "dropped", "errors", "camera", "passthrough_active", "keyword", "gain", "range" (the
//           _SHPassthroughRange uploaded), "log2_lo", "log2_hi" (the camera's), "lut_uploaded"}.
using System;
using System.Collections.Generic;
using System.Globalization;
using System.Text;
using System.Threading;
using Shlight.Lighting;

static class PassthroughTest
{
    static int Main(string[] args)
    {
        CultureInfo.DefaultThreadCurrentCulture = CultureInfo.InvariantCulture;
        Thread.CurrentThread.CurrentCulture = CultureInfo.InvariantCulture;
        switch (args[0])
        {
            case "lut": return Lut();
            case "render": return Render();
#if SHLIGHT_MRUK
            case "sender": return Sender.Run(args[1], Harness.Text(args[2]), Harness.Double(args[3]));
#endif
            default: Console.Error.WriteLine("unknown mode " + args[0]); return 2;
        }
    }

    static int Lut()
    {
        Sh9PassthroughCamera camera = Sh9PassthroughCamera.FromJson(MiniJson.ParseObject(Console.In.ReadLine()));
        var xs = (List<object>)MiniJson.Parse(Console.In.ReadLine());
        var display = new List<double>();
        foreach (object o in xs)
        {
            double[] x = Harness.Numbers(o);
            for (int c = 0; c < 3; c++) display.Add(camera.Display(c, x[c]));
        }
        var lut = new double[camera.Lut.Length];
        for (int i = 0; i < lut.Length; i++) lut[i] = camera.Lut[i];
        Console.WriteLine("{\"log2_lo\":" + Harness.Num(camera.Log2Lo) + ",\"log2_hi\":" + Harness.Num(camera.Log2Hi) +
                          ",\"toe_scale\":" + Harness.Num(camera.ToeScale) + ",\"lut\":" +
                          Harness.Array(lut) + ",\"display\":" + Harness.Array(display) + "}");
        return 0;
    }

    static int Render()
    {
        var state = new Sh9PassthroughState();
        if (state.Handle(Console.In.ReadLine()) != Sh9PassthroughKind.Camera) throw new Exception("line 1: not a camera");
        Sh9Parsed sh9 = Sh9Protocol.Parse(Console.In.ReadLine());
        var snap = new Sh9Snapshot(sh9.Sh9, 0, 1);
        var values = new Sh9LightingValues();
        values.Set(snap, 0, 0, 0, 1, 1.0, false);        // what SH9LightingClient uploads (no rotation, Intensity 1)
        var m = new double[48];
        for (int i = 0; i < 48; i++) m[i] = values.Matrices[i];
        Sh9PassthroughCamera camera = state.Camera;
        string line;
        while ((line = Console.In.ReadLine()) != null && line.Trim().Length > 0)
        {
            if (state.Handle(line) != Sh9PassthroughKind.Answer) throw new Exception("not an answer: " + line);
            var scene = MiniJson.ParseObject(Console.In.ReadLine());
            double albedo = (double)scene["albedo"];
            var gain = new double[3];
            if (!state.Gain(0, gain)) throw new Exception("no gain");
            var display = new StringBuilder("[");
            bool first = true;
            foreach (object o in (List<object>)scene["normals"])
            {
                double[] n = Harness.Numbers(o);
                var rgb = new double[3];
                for (int c = 0; c < 3; c++)
                {
                    // Unity's frame: z -> -z (docs/contract.md §1), as the vertex stage's world normal is
                    double e = Math.Max(0, Sh9Math.Irradiance(m, c, n[0], n[1], -n[2]));
                    rgb[c] = camera.Display(c, albedo * e / Math.PI * gain[c]);
                }
                display.Append(first ? "" : ",").Append(Harness.Array(rgb));
                first = false;
            }
            display.Append(']');
            Console.WriteLine("{\"display\":" + display + ",\"gain\":" + Harness.Array(gain) + ",\"matrices\":" + Harness.Array(m) +
                              ",\"log2_lo\":" + Harness.Num(camera.Log2Lo) + ",\"log2_hi\":" + Harness.Num(camera.Log2Hi) +
                              ",\"toe_scale\":" + Harness.Num(camera.ToeScale) + "}");
        }
        return 0;
    }

#if SHLIGHT_MRUK
    static class Sender
    {
        static UnityEngine.Quaternion Q(double[] q) { return new UnityEngine.Quaternion((float)q[0], (float)q[1], (float)q[2], (float)q[3]); }
        static UnityEngine.Vector3 V(double[] p) { return new UnityEngine.Vector3((float)p[0], (float)p[1], (float)p[2]); }

        public static int Run(string url, string token, double seconds)
        {
            var views = new List<Dictionary<string, object>>();
            string line;
            while ((line = Console.In.ReadLine()) != null && line.Trim().Length > 0) views.Add(MiniJson.ParseObject(line));
            var anchor = new UnityEngine.GameObject("Anchor");
            var client = anchor.AddComponent<SH9LightingClient>();
            client.ServerUrl = url;
            client.Token = token;
            client.Probe = "";
            client.ExposureMode = Sh9ExposureMode.Passthrough;
            Harness.SetField(client, "logToConsole", false);
            var camGo = new UnityEngine.GameObject("Camera");
            var access = camGo.AddComponent<Meta.XR.PassthroughCameraAccess>();
            var sender = anchor.AddComponent<SH9PassthroughSender>();
            sender.CameraAccess = access;
            sender.LightingClient = client;
            sender.ViewsPerSecond = 30f;
            Harness.Call(client, "OnEnable");
            Harness.Call(sender, "OnEnable");
            var deadline = DateTime.UtcNow.AddSeconds(seconds);
            Action frame = () =>
            {
                UnityEngine.Time.StandInFrameCount++;
                Harness.Call(client, "Update");
                Harness.Call(sender, "Update");
                access.StandInUpdatedThisFrame = false;
                Thread.Sleep(10);
            };
            foreach (var v in views)
            {
                double[] anchorPos = Harness.Numbers(v["anchor_position"]), anchorRot = Harness.Numbers(v["anchor_rotation"]);
                anchor.transform.position = V(anchorPos);
                anchor.transform.rotation = Q(anchorRot);
                double[] size = Harness.Numbers(v["size"]), focal = Harness.Numbers(v["focal"]), principal = Harness.Numbers(v["principal"]);
                double[] sensor = Harness.Numbers(v["sensor"]);
                access.CurrentResolution = new UnityEngine.Vector2Int((int)size[0], (int)size[1]);
                access.Intrinsics = new Meta.XR.PassthroughCameraAccess.CameraIntrinsics
                {
                    FocalLength = new UnityEngine.Vector2((float)focal[0], (float)focal[1]),
                    PrincipalPoint = new UnityEngine.Vector2((float)principal[0], (float)principal[1]),
                    SensorResolution = new UnityEngine.Vector2Int((int)sensor[0], (int)sensor[1]),
                };
                access.StandInPose = new UnityEngine.Pose(V(Harness.Numbers(v["position"])), Q(Harness.Numbers(v["rotation"])));
                access.Timestamp = new DateTime(1970, 1, 1, 0, 0, 0, DateTimeKind.Utc).AddTicks((long)((double)v["time"] * 1e7));
                // the camera's image lands on the render thread of this frame: the sender reads it next frame
                var tex = new UnityEngine.Texture2D((int)size[0], (int)size[1], UnityEngine.TextureFormat.RGBA32, false);
                tex.StandInBytes = Convert.FromBase64String((string)v["jpeg"]);
                access.StandInTexture = tex;
                access.StandInPlaying = true;
                access.StandInUpdatedThisFrame = true;
                long before = sender.Capture.ViewsSent, answers = sender.Capture.State.Answers + sender.Capture.State.Errors;
                while (sender.Capture.ViewsSent == before && DateTime.UtcNow < deadline)
                {
                    long skipped = sender.Capture.ViewsSkipped;
                    frame();
                    // the sender took the image but the socket refused the view: the next camera image, the same
                    // view again. Only then: an image taken while one waits would go out as the next view.
                    if (sender.Capture.ViewsSent == before && sender.Capture.ViewsSkipped != skipped)
                        access.StandInUpdatedThisFrame = true;
                }
                Console.WriteLine("{\"sent\":" + MiniJson.Quote(sender.LastViewMessage ?? "") + "}");
                while (sender.Capture.State.Answers + sender.Capture.State.Errors == answers && DateTime.UtcNow < deadline) frame();
                Console.Out.Flush();
            }
            for (int i = 0; i < 3; i++) frame();     // the last answer reaches the client's globals
            Sh9PassthroughState st = sender.Capture.State;
            UnityEngine.Vector4 g;
            UnityEngine.Shader.StandInGlobalVectors.TryGetValue(UnityEngine.Shader.PropertyToID("_SHPassthroughGain"), out g);
            UnityEngine.Vector4 range;
            UnityEngine.Shader.StandInGlobalVectors.TryGetValue(UnityEngine.Shader.PropertyToID("_SHPassthroughRange"), out range);
            Console.WriteLine("{\"answers\":" + st.Answers + ",\"dropped\":" + st.Dropped + ",\"errors\":" + st.Errors +
                              ",\"last_error\":" + MiniJson.Quote(st.LastError ?? "") +
                              ",\"camera\":" + (st.Camera != null ? "true" : "false") +
                              ",\"exposure\":" + Harness.Num(st.Answer == null ? double.NaN : st.Answer.Exposure) +
                              ",\"passthrough_active\":" + (client.PassthroughActive ? "true" : "false") +
                              ",\"keyword\":" + (UnityEngine.Shader.IsKeywordEnabled("SH9_PASSTHROUGH") ? "true" : "false") +
                              ",\"gain\":" + Harness.Array(new double[] { g.x, g.y, g.z }) +
                              ",\"range\":" + Harness.Array(new double[] { range.x, range.y, range.z }) +
                              ",\"log2_lo\":" + Harness.Num(st.Camera == null ? double.NaN : st.Camera.Log2Lo) +
                              ",\"log2_hi\":" + Harness.Num(st.Camera == null ? double.NaN : st.Camera.Log2Hi) +
                              ",\"lut_uploaded\":" + (client.PassthroughLut != null ? "true" : "false") + "}");
            Harness.Call(sender, "OnDisable");
            Harness.Call(client, "OnDisable");
            return 0;
        }
    }
#endif
}
