// Lights the scene from a running `shlight serve`: receives SH9 coefficients over a WebSocket
// (Sh9Client, off the main thread) and, on the main thread in Update, sets the global shader
// matrices _SHIrradianceR/G/B (Unity frame, re-oriented by this transform) and optionally
// RenderSettings.ambientProbe so that Unity's own shaders follow the room too.
using System;
using System.Collections.Concurrent;
using UnityEngine;
using UnityEngine.Rendering;

namespace Shlight.Lighting
{
    [AddComponentMenu("Lighting/SH9 Lighting Client (shlight)")]
    [DisallowMultipleComponent]
    public sealed class SH9LightingClient : MonoBehaviour
    {
        [Header("Server (the PC running `shlight serve --host 0.0.0.0`)")]
        [Tooltip("ws://PC-ADDRESS:8765/  (HOST:PORT is accepted too)")]
        [SerializeField] string serverUrl = "ws://192.168.1.100:8765/";
        [Tooltip("The server's --token. Sent as 'Authorization: Bearer <token>'.")]
        [SerializeField] string token = "";
        [Tooltip("Also send the token as ?token=... (only if a proxy strips the header).")]
        [SerializeField] bool tokenInQuery = false;
        [Tooltip("Probe name to subscribe to (see the server's hello). Empty: whatever the server sends.")]
        [SerializeField] string probe = "default";
        [Tooltip("Highest message rate to ask for.")]
        [Range(1f, 120f)]
        [SerializeField] float maxHz = 30f;

        [Header("Lighting")]
        [Tooltip("Linear multiplier on the received irradiance (exposure match between camera and display).")]
        [Min(0f)]
        [SerializeField] float intensity = 1f;
        [Tooltip("Re-orient the probe by this transform's rotation (attach to the image target / anchor " +
                 "that marks where the camera is and how it is turned). Off: the probe's axes are world axes.")]
        [SerializeField] bool followTransformRotation = true;
        [Tooltip("Also set RenderSettings.ambientProbe so that Standard/URP Lit shaders follow the room " +
                 "(switches ambient mode to Skybox while enabled; restored on disable).")]
        [SerializeField] bool driveAmbientProbe = false;
        [Tooltip("Uniform radiance used until the first message arrives (a flat grey means: no data yet).")]
        [SerializeField] Color fallbackRadiance = new Color(0.5f, 0.5f, 0.5f, 1f);
        [Tooltip("Seconds without a message before the state becomes Stale.")]
        [Min(0.5f)]
        [SerializeField] float staleAfterSeconds = 3f;
        [SerializeField] bool logToConsole = true;

        static readonly int IdR = Shader.PropertyToID("_SHIrradianceR");
        static readonly int IdG = Shader.PropertyToID("_SHIrradianceG");
        static readonly int IdB = Shader.PropertyToID("_SHIrradianceB");

        Sh9Client client;
        string clientConfig;
        readonly ConcurrentQueue<string> logQueue = new ConcurrentQueue<string>();
        readonly Sh9LightingValues values = new Sh9LightingValues();
        Matrix4x4 matrixR = default(Matrix4x4), matrixG = default(Matrix4x4), matrixB = default(Matrix4x4);
        SphericalHarmonicsL2 ambient = default(SphericalHarmonicsL2);
        long appliedVersion = -1;
        Quaternion appliedRotation;
        float appliedIntensity = float.NaN;
        bool savedAmbient;
        AmbientMode savedAmbientMode;
        SphericalHarmonicsL2 savedAmbientProbe;
        Sh9ConnectionState state = Sh9ConnectionState.Disconnected;

        /// <summary>Raised on the main thread when <see cref="State"/> changes.</summary>
        public event Action<Sh9ConnectionState> StateChanged;

        public Sh9ConnectionState State { get { return state; } }
        /// <summary>True once real coefficients have been applied (not just the fallback).</summary>
        public bool HasLighting { get; private set; }
        /// <summary>seq of the applied message (-1 before the first).</summary>
        public long LastSeq { get; private set; }
        /// <summary>Seconds since the applied coefficients were captured (-1 before the first).</summary>
        public float AgeSeconds { get; private set; }
        public bool LastMessageStale { get; private set; }
        /// <summary>Why the connection is failing right now (wrong token, server unreachable, ...);
        /// null while connected without complaint.</summary>
        public string LastError { get; private set; }
        /// <summary>HTTP status of the last refused handshake (401: wrong token); 0 if none.</summary>
        public int HandshakeStatus { get { return client == null ? 0 : client.HandshakeStatus; } }
        public int Connections { get { return client == null ? 0 : client.Connections; } }
        public long MessagesReceived { get { return client == null ? 0 : client.MessagesReceived; } }
        public Sh9Hello ServerHello { get { return client == null ? null : client.Hello; } }
        /// <summary>The applied message (right-handed wire values and statistics), or null.</summary>
        public Sh9Message LastMessage { get; private set; }
        /// <summary>The values last uploaded (Unity world frame, rotation and intensity applied).</summary>
        public Sh9LightingValues Values { get { return values; } }

        public string ServerUrl { get { return serverUrl; } set { serverUrl = value; } }
        public string Token { get { return token; } set { token = value; } }
        public string Probe { get { return probe; } set { probe = value; } }
        public float Intensity { get { return intensity; } set { intensity = Mathf.Max(0f, value); } }
        public bool DriveAmbientProbe { get { return driveAmbientProbe; } set { driveAmbientProbe = value; } }

        void OnEnable()
        {
            LastSeq = -1;
            AgeSeconds = -1f;
            Connect();
        }

        void OnDisable()
        {
            Disconnect();
            RestoreAmbient();
        }

        /// <summary>(Re)connect with the current settings.</summary>
        public void Connect()
        {
            Disconnect();
            clientConfig = ConfigKey();
            try
            {
                client = new Sh9Client(new Sh9ClientOptions
                {
                    Url = serverUrl,
                    Token = token,
                    TokenInQuery = tokenInQuery,
                    Probe = probe,
                    MaxHz = maxHz,
                    StaleAfterSeconds = staleAfterSeconds,
                });
            }
            catch (ArgumentException e)
            {
                LastError = e.Message;
                Debug.LogError("[SH9] " + e.Message, this);
                return;
            }
            client.Log += message => logQueue.Enqueue(message);
            client.Start();
        }

        public void Disconnect()
        {
            if (client == null) return;
            client.Stop(500);
            client = null;
        }

        string ConfigKey()
        {
            return serverUrl + "\n" + token + "\n" + tokenInQuery + "\n" + probe + "\n" + maxHz + "\n" + staleAfterSeconds;
        }

        void Update()
        {
            if (clientConfig != ConfigKey()) Connect(); // changed in the inspector or by script

            string line;
            while (logQueue.TryDequeue(out line))
                if (logToConsole) Debug.Log("[SH9] " + line, this);

            Sh9Snapshot snap = client == null ? null : client.Latest;
            Quaternion rotation = followTransformRotation ? transform.rotation : Quaternion.identity;
            if (snap != null)
            {
                if (snap.Version != appliedVersion || !SameRotation(rotation, appliedRotation) || intensity != appliedIntensity)
                {
                    values.Set(snap.UnityMatrices, Sh9Math.QuaternionToMatrix(rotation.x, rotation.y, rotation.z, rotation.w),
                               intensity);
                    appliedVersion = snap.Version;
                    appliedRotation = rotation;
                    appliedIntensity = intensity;
                    CopyValues();
                    HasLighting = true;
                    LastMessage = snap.Message;
                    LastSeq = snap.Message.Seq;
                }
                LastMessageStale = snap.Message.Stale;
                AgeSeconds = (float)(snap.Message.AgeSeconds + snap.SecondsSinceReceived);
            }
            else
            {
                // no data yet: a uniform fallback (re-evaluated so that colour/intensity edits show)
                Color linear = fallbackRadiance.linear;
                values.SetUniform(linear.r * intensity, linear.g * intensity, linear.b * intensity);
                CopyValues();
            }

            // Globals every frame: cheap, and survives anything else that touches them.
            Shader.SetGlobalMatrix(IdR, matrixR);
            Shader.SetGlobalMatrix(IdG, matrixG);
            Shader.SetGlobalMatrix(IdB, matrixB);
            if (driveAmbientProbe)
            {
                if (!savedAmbient)
                {
                    savedAmbientMode = RenderSettings.ambientMode;
                    savedAmbientProbe = RenderSettings.ambientProbe;
                    savedAmbient = true;
                }
                if (RenderSettings.ambientMode != AmbientMode.Skybox && RenderSettings.ambientMode != AmbientMode.Custom)
                    RenderSettings.ambientMode = AmbientMode.Skybox;
                RenderSettings.ambientProbe = ambient;
            }
            else
            {
                RestoreAmbient();
            }

            Sh9ConnectionState now = client == null ? Sh9ConnectionState.Disconnected : client.State;
            if (client != null) LastError = client.LastError; // null again once a connection works
            if (now != state)
            {
                state = now;
                if (logToConsole) Debug.Log("[SH9] state: " + now, this);
                Action<Sh9ConnectionState> handler = StateChanged;
                if (handler != null) handler(now);
            }
        }

        // Exact comparison (Quaternion == tolerates ~0.1°, which would skip slow anchor drift).
        static bool SameRotation(Quaternion a, Quaternion b)
        {
            return a.x == b.x && a.y == b.y && a.z == b.z && a.w == b.w;
        }

        void CopyValues()
        {
            float[] m = values.Matrices;
            for (int row = 0; row < 4; row++)
            {
                for (int col = 0; col < 4; col++)
                {
                    matrixR[row, col] = m[4 * row + col];
                    matrixG[row, col] = m[16 + 4 * row + col];
                    matrixB[row, col] = m[32 + 4 * row + col];
                }
            }
            float[] sh = values.AmbientProbe;
            for (int c = 0; c < 3; c++)
                for (int i = 0; i < 9; i++)
                    ambient[c, i] = sh[9 * c + i];
        }

        void RestoreAmbient()
        {
            if (!savedAmbient) return;
            RenderSettings.ambientMode = savedAmbientMode;
            RenderSettings.ambientProbe = savedAmbientProbe;
            savedAmbient = false;
        }
    }
}
