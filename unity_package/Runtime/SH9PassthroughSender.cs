// Sends the headset's own camera to `shlight serve --passthrough` (docs/passthrough.md, "Unity on Quest"): Meta's
// Passthrough Camera API (MRUK's PassthroughCameraAccess, Quest 3/3S, Horizon OS v74+) gives each camera image
// with its intrinsics and the camera's pose at the image's timestamp; this component sends, a few times a
// second, one "view" message (the pose in the probe's frame, the intrinsics, the time) and the image as a JPEG
// on /capture (the lighting client's server, token and probe), and hands the server's answers (the view's
// exposure and white balance, the camera's curve) to the SH9LightingClient, whose Exposure Mode Passthrough
// renders SH9 Diffuse through them.
//
// Off by default twice over: it compiles to an empty component unless the project defines SHLIGHT_MRUK (Player
// Settings > Scripting Define Symbols, with Meta's MRUK package installed), and it sends nothing until enabled.
// It sends at most one view at a time: the next waits for the last one's answer (a slow server or Wi-Fi costs
// views, never a queue).
#if SHLIGHT_MRUK
using System;
using Meta.XR;
#endif
using UnityEngine;

namespace Shlight.Lighting
{
    [AddComponentMenu("Lighting/SH9 Passthrough Sender (shlight, Meta Quest camera)")]
    [DisallowMultipleComponent]
    public sealed class SH9PassthroughSender : MonoBehaviour
    {
#if SHLIGHT_MRUK
        [Tooltip("MRUK's PassthroughCameraAccess (the headset permission horizonos.permission.HEADSET_CAMERA).")]
        [SerializeField] PassthroughCameraAccess cameraAccess;
        [Tooltip("The lighting client whose server, token and probe the views go to; its transform is the probe's " +
                 "anchor (where the 360° camera is and how it is turned), its Exposure Mode Passthrough renders " +
                 "through the answers.")]
        [SerializeField] SH9LightingClient lightingClient;
        [Tooltip("Views sent a second at most (the server fits up to --passthrough-hz, 10 by default).")]
        [Range(0.2f, 30f)]
        [SerializeField] float viewsPerSecond = 5f;
        [Tooltip("Views wider than this are scaled down before encoding (the fit samples ~2,500 pixels a view).")]
        [Min(16)]
        [SerializeField] int maxWidth = 320;
        [Range(1, 100)]
        [SerializeField] int jpegQuality = 85;

        static readonly DateTime UnixEpoch = new DateTime(1970, 1, 1, 0, 0, 0, DateTimeKind.Utc);

        Sh9CaptureClient capture;
        RenderTexture scaled;
        Texture2D readback;
        bool pending;
        Pose pendingPose;
        double pendingTime;
        int pendingFrame;
        float lastSent = float.NegativeInfinity;
        readonly double[] cameraPosition = new double[3], cameraRotation = new double[4];
        readonly double[] anchorPosition = new double[3], anchorRotation = new double[4];

        public PassthroughCameraAccess CameraAccess { get { return cameraAccess; } set { cameraAccess = value; } }
        public SH9LightingClient LightingClient { get { return lightingClient; } set { lightingClient = value; } }
        public float ViewsPerSecond { get { return viewsPerSecond; } set { viewsPerSecond = Mathf.Max(0.01f, value); } }
        public int MaxWidth { get { return maxWidth; } set { maxWidth = Math.Max(16, value); } }
        /// <summary>The socket on /capture (null while disabled): views sent and skipped, its state.</summary>
        public Sh9CaptureClient Capture { get { return capture; } }
        /// <summary>The last "view" message sent (null before the first).</summary>
        public string LastViewMessage { get; private set; }

        void OnEnable()
        {
            if (lightingClient == null) lightingClient = GetComponent<SH9LightingClient>();
            if (lightingClient == null || cameraAccess == null)
            {
                Debug.LogError("[SH9] Passthrough Sender: assign a PassthroughCameraAccess and an SH9LightingClient", this);
                enabled = false;
                return;
            }
            try
            {
                capture = new Sh9CaptureClient(lightingClient.ServerUrl, lightingClient.Token, lightingClient.TokenInQuery,
                                              lightingClient.Probe);
            }
            catch (ArgumentException e)
            {
                Debug.LogError("[SH9] Passthrough Sender: " + e.Message, this);
                enabled = false;
                return;
            }
            lightingClient.Passthrough = capture.State;
            capture.Start();
        }

        void OnDisable()
        {
            if (capture != null) capture.Stop();
            capture = null;
            pending = false;
            if (scaled != null) scaled.Release();
            scaled = null;
        }

        void Update()
        {
            if (capture == null || !cameraAccess.IsPlaying) return;
            // GetTexture() is written on the render thread before the frame is shown: a Blit now reads the image
            // of the last update before this frame, whose pose was taken in that frame. So a view pairs the image
            // read now with the pose kept then, never with this frame's.
            if (pending && pendingFrame < Time.frameCount && Time.unscaledTime - lastSent >= 1f / viewsPerSecond &&
                capture.Connected)
            {
                if (Send()) lastSent = Time.unscaledTime;
                pending = false;
            }
            if (cameraAccess.IsUpdatedThisFrame)
            {
                pendingPose = cameraAccess.GetCameraPose();
                pendingTime = (cameraAccess.Timestamp.ToUniversalTime() - UnixEpoch).TotalSeconds;
                pendingFrame = Time.frameCount;
                pending = true;
            }
        }

        bool Send()
        {
            Vector2Int size = cameraAccess.CurrentResolution;
            int w = size.x, h = size.y;
            if (w <= 0 || h <= 0) return false;
            if (w > maxWidth)
            {
                h = Math.Max(1, (int)Math.Round(h * (double)maxWidth / w));
                w = maxWidth;
            }
            if (scaled == null || scaled.width != w || scaled.height != h)
            {
                if (scaled != null) scaled.Release();
                // sRGB: the camera's 8-bit codes go through unchanged (a linear target would decode them)
                scaled = new RenderTexture(w, h, 0, RenderTextureFormat.ARGB32, RenderTextureReadWrite.sRGB);
                scaled.Create();
                readback = new Texture2D(w, h, TextureFormat.RGB24, false);
            }
            Graphics.Blit(cameraAccess.GetTexture(), scaled);
            RenderTexture previous = RenderTexture.active;
            RenderTexture.active = scaled;
            readback.ReadPixels(new Rect(0, 0, w, h), 0, 0);
            readback.Apply(false);
            RenderTexture.active = previous;
            byte[] jpeg = ImageConversion.EncodeToJPG(readback, jpegQuality);

            PassthroughCameraAccess.CameraIntrinsics k = cameraAccess.Intrinsics;
            double[] intrinsics = Sh9CaptureView.Intrinsics(k.FocalLength.x, k.FocalLength.y, k.PrincipalPoint.x,
                                                           k.PrincipalPoint.y, k.SensorResolution.x,
                                                           k.SensorResolution.y, w, h);
            Vector3 p = pendingPose.position, a = lightingClient.transform.position;
            Quaternion q = pendingPose.rotation, r = lightingClient.ProbeRotation;
            cameraPosition[0] = p.x; cameraPosition[1] = p.y; cameraPosition[2] = p.z;
            cameraRotation[0] = q.x; cameraRotation[1] = q.y; cameraRotation[2] = q.z; cameraRotation[3] = q.w;
            anchorPosition[0] = a.x; anchorPosition[1] = a.y; anchorPosition[2] = a.z;
            anchorRotation[0] = r.x; anchorRotation[1] = r.y; anchorRotation[2] = r.z; anchorRotation[3] = r.w;
            double[] matrix = Sh9CaptureView.TransformMatrix(cameraPosition, cameraRotation, anchorPosition, anchorRotation);
            string message = Sh9CaptureView.Message(matrix, intrinsics, w, h, pendingTime);
            if (!capture.TrySend(message, jpeg)) return false;
            LastViewMessage = message;
            return true;
        }
#else
        void OnEnable()
        {
            Debug.LogWarning("[SH9] Passthrough Sender needs Meta's MRUK (PassthroughCameraAccess) and the scripting define " +
                             "SHLIGHT_MRUK; it does nothing without them", this);
            enabled = false;
        }
#endif
    }
}
