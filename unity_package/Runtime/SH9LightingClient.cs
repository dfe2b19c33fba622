// Lights the scene from a running `shlight serve`: receives SH9 coefficients over a WebSocket
// (Sh9Client, off the main thread) and, on the main thread in Update, sets the global shader
// matrices _SHIrradianceR/G/B (Unity frame, re-oriented by this transform), optionally
// RenderSettings.ambientProbe so that Unity's own shaders follow the room too, and optionally a
// Directional Light from the first light the server splits off (docs/contract.md §10).
//
// Update allocates nothing in the steady state (measured under Mono by tests/csharp/LiveClient.cs):
// settings are compared field by field, the conversion works in preallocated buffers, and Unity
// is only given structs.
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

        [Header("Directional light (when the server splits off lights)")]
        [Tooltip("A Directional Light to show the server's first light (sun, a bright window) as a real " +
                 "light: direction, colour and intensity are set every message, and the SH9 globals and " +
                 "ambient probe then get the rest of the room only, so the light is not counted twice. " +
                 "Empty: every light stays in the SH9. The light is switched off while the server sends none.")]
        [SerializeField] Light directionalLight;

        [Header("Shadows (docs/shadows_consumers.md)")]
        [Tooltip("The Directional Light shows the key light (the brightest of the server's lights, not the first) " +
                 "and casts its shadows: Soft when the light's angular radius is 0.5° or more (a lamp, a window), " +
                 "Hard below (the sun), strength 1. Put an SH9 Shadow Catcher material on the real floor's " +
                 "stand-in to darken the passthrough image where the key light is blocked.")]
        [SerializeField] bool keyLightShadows = false;

        [Header("Photometry (docs/unity.md: a provider calibrated with a lux meter)")]
        [Tooltip("Relative: as sent × Intensity (default). Camera Image (URP/built-in, passthrough): absolute lighting " +
                 "× 1/(1.2·2^EV100), a surface renders at the brightness of a camera exposed for the room. Physical " +
                 "Camera (HDRP): SH9 and the Directional Light in lux, the camera takes the EV100. Passthrough (video see-through " +
                 "with SH9 Passthrough Sender, docs/passthrough.md): SH9 Diffuse shows the code the headset's camera gives " +
                 "the real replica. Relative messages stay as sent in every mode.")]
        [SerializeField] Sh9ExposureMode exposureMode = Sh9ExposureMode.Relative;
        [Tooltip("Stops added to the room's exposure (+1: twice as bright); absolute lighting, and Passthrough.")]
        [SerializeField] float exposureCompensation = 0f;
        [Tooltip("Physical Camera mode, Unity 2022.2+: this camera's shutterSpeed is set so that its aperture and " +
                 "ISO give the room's EV100 (HDRP Exposure override in Physical Camera mode). Empty: read CameraEv100.")]
        [SerializeField] Camera physicalCamera;
        [Tooltip("Colour the Directional Light by the light's colour temperature (light_cct_k, else cct_k) " +
                 "instead of its RGB, with its luminance kept. Needs the linear colour space; turns on " +
                 "GraphicsSettings.lightsUseLinearIntensity and lightsUseColorTemperature (restored on disable). " +
                 "A message without CCT keeps the RGB colour.")]
        [SerializeField] bool useColorTemperature = false;

        static readonly int IdR = Shader.PropertyToID("_SHIrradianceR");
        static readonly int IdG = Shader.PropertyToID("_SHIrradianceG");
        static readonly int IdB = Shader.PropertyToID("_SHIrradianceB");
        // 1 while the driven light carries part of the room's light: SH9 Diffuse then adds the main
        // directional light to SHIrradiance; 0 otherwise (a scene's own default light is not added).
        static readonly int IdMainLightScale = Shader.PropertyToID("_SHMainLightScale");
        // sh9_lights.hlsl's lights (docs/contract.md §10): the drawn light in slot 0, the others after it (the SH9
        // globals hold them too, as their SH9 projections); the shadow catchers read them.
        static readonly int IdLightCount = Shader.PropertyToID("_SHLightCount");
        // Passthrough mode (SH9DiffusePasses.hlsl, SH9_PASSTHROUGH): the display lookup, the view's gain, its range
        // (lo, 1 / (hi − lo), 2^−lo: the toe below the first entry).
        const string PassthroughKeyword = "SH9_PASSTHROUGH";
        static readonly int IdPassthroughLut = Shader.PropertyToID("_SHPassthroughLut");
        static readonly int IdPassthroughGain = Shader.PropertyToID("_SHPassthroughGain");
        static readonly int IdPassthroughRange = Shader.PropertyToID("_SHPassthroughRange");
        Sh9PassthroughState passthrough;
        Sh9PassthroughCamera uploadedCamera;
        Texture2D passthroughLut;
        readonly Color[] lutColors = new Color[Sh9PassthroughCamera.LutSize];
        readonly double[] passthroughGain = new double[3];
        bool keywordOn;
        static readonly int IdLightDirection = Shader.PropertyToID("_SHLightDirection");
        static readonly int IdLightIrradiance = Shader.PropertyToID("_SHLightIrradiance");
        static readonly int IdLightAngularRadius = Shader.PropertyToID("_SHLightAngularRadius");
        readonly Vector4[] lightDirections = new Vector4[4];
        readonly Vector4[] lightIrradiances = new Vector4[4];

        Sh9Client client;
        // the settings the running client was made with (compared field by field: no garbage per frame)
        string usedUrl, usedToken, usedProbe;
        bool usedTokenInQuery, usedEnvironment, usedKeyLight;
        bool receiveEnvironment;
        float usedMaxHz, usedStaleAfter;
        readonly ConcurrentQueue<string> logQueue = new ConcurrentQueue<string>();
        readonly Sh9LightingValues values = new Sh9LightingValues();
        Matrix4x4 matrixR = default(Matrix4x4), matrixG = default(Matrix4x4), matrixB = default(Matrix4x4);
        SphericalHarmonicsL2 ambient = default(SphericalHarmonicsL2);
        long appliedVersion = -1;
        Quaternion appliedRotation;
        float appliedIntensity = float.NaN;
        Light appliedLight;
        Sh9LightColorSpace appliedColorSpace = (Sh9LightColorSpace)(-1);
        Sh9ExposureMode appliedMode;
        float appliedCompensation;
        bool appliedUseTemperature;
        Camera appliedCamera;
        Sh9Exposure exposure = Sh9Exposure.Resolve(null, Sh9ExposureMode.Relative, 0);
        double appliedKelvin = double.NaN;
        bool changedGraphicsSettings, savedLinearIntensity, savedUseTemperature, warnedGammaTemperature;
#if UNITY_2022_2_OR_NEWER
        Camera savedCamera;
        float savedShutterSpeed;
#endif
        float savedLightTemperature;
        bool savedAmbient;
        AmbientMode savedAmbientMode;
        SphericalHarmonicsL2 savedAmbientProbe;
        Light savedLight;
        bool savedLightEnabled, savedLightColorTemperature;
        LightShadows savedLightShadows;
        float savedLightShadowStrength;
        Color savedLightColor;
        float savedLightIntensity;
        Quaternion savedLightRotation;
        bool lightDriven;
        readonly double[] lightRotation = new double[4];
        readonly double[] lightColor = new double[4];
        double lastForcedReconnect = double.NegativeInfinity;
        Sh9ConnectionState state = Sh9ConnectionState.Disconnected;

        /// <summary>On regaining focus, reconnect at once when nothing arrived for this long (the
        /// server sends at least every --keepalive, 1 s by default).</summary>
        const double FocusSilenceSeconds = 2.5;

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
        /// <summary>Also send the token as ?token=... (changing it reconnects).</summary>
        public bool TokenInQuery { get { return tokenInQuery; } set { tokenInQuery = value; } }
        public string Probe { get { return probe; } set { probe = value; } }
        public float Intensity { get { return intensity; } set { intensity = Mathf.Max(0f, value); } }
        public bool DriveAmbientProbe { get { return driveAmbientProbe; } set { driveAmbientProbe = value; } }
        /// <summary>The Directional Light driven from the server's first light (null: none).</summary>
        public Light DirectionalLight { get { return directionalLight; } set { directionalLight = value; } }
        /// <summary>Also receive the reflection cube (set by SH9Reflections; changing it reconnects).</summary>
        public bool ReceiveEnvironment { get { return receiveEnvironment; } set { receiveEnvironment = value; } }

        /// <summary>Draw the key light (the brightest) and let it cast shadows (Soft from 0.5° of angular radius);
        /// takes effect at the next frame (reconnecting).</summary>
        public bool KeyLightShadows { get { return keyLightShadows; } set { keyLightShadows = value; } }

        /// <summary>Angular radius (degrees) of the light the Directional Light shows (0: none sent, or no light).</summary>
        public float LightAngularRadiusDeg { get { return lightDriven ? (float)values.LightAngularRadiusDeg : 0f; } }
        /// <summary>The newest reflection cube received (null until the first, or without ReceiveEnvironment).</summary>
        public Sh9EnvironmentSnapshot LatestEnvironment { get { return client == null ? null : client.LatestEnvironment; } }
        /// <summary>The orientation the lighting is turned by: this transform's rotation (Follow Transform
        /// Rotation) or identity. SH9Reflections bakes the cube with the same one.</summary>
        public Quaternion ProbeRotation { get { return followTransformRotation ? transform.rotation : Quaternion.identity; } }
        public bool FollowTransformRotation { get { return followTransformRotation; } set { followTransformRotation = value; } }
        /// <summary>True while <see cref="DirectionalLight"/> shows a light the server split off.</summary>
        public bool LightActive { get { return lightDriven; } }

        public Sh9ExposureMode ExposureMode { get { return exposureMode; } set { exposureMode = value; } }
        public float ExposureCompensation { get { return exposureCompensation; } set { exposureCompensation = value; } }
        public Camera PhysicalCamera { get { return physicalCamera; } set { physicalCamera = value; } }
        public bool UseColorTemperature { get { return useColorTemperature; } set { useColorTemperature = value; } }
        /// <summary>The headset camera's fit this client renders through in Passthrough mode (SH9PassthroughSender sets
        /// it; another sender may set its own or feed <see cref="HandlePassthroughMessage"/>).</summary>
        public Sh9PassthroughState Passthrough
        {
            get { if (passthrough == null) passthrough = new Sh9PassthroughState(); return passthrough; }
            set { passthrough = value; }
        }
        /// <summary>True while SH9 Diffuse renders through the headset's camera (Passthrough mode, a camera and an
        /// answer received).</summary>
        public bool PassthroughActive { get; private set; }
        /// <summary>The display lookup uploaded (256 × 1, RGBA float), or null.</summary>
        public Texture2D PassthroughLut { get { return passthroughLut; } }

        /// <summary>Take one "passthrough" or "passthrough_camera" message (any thread).</summary>
        public Sh9PassthroughKind HandlePassthroughMessage(string json) { return Passthrough.Handle(json); }
        /// <summary>The exposure applied to the last message (Scale 1, CameraEv100 NaN for relative lighting).</summary>
        public Sh9Exposure AppliedExposure { get { return exposure; } }
        /// <summary>The EV100 a physical camera should use (Physical Camera mode, absolute lighting); NaN otherwise.
        /// HDRP: a Volume's Exposure override in Fixed mode takes it as fixedExposure.</summary>
        public float CameraEv100 { get { return (float)exposure.CameraEv100; } }
        /// <summary>The colour temperature (kelvin) the Directional Light shows; NaN when it shows RGB.</summary>
        public float LightColorTemperatureK { get { return lightDriven ? (float)appliedKelvin : float.NaN; } }

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
            RestoreLight();
            RestoreCamera();
            RestoreGraphicsSettings();
            Shader.SetGlobalFloat(IdMainLightScale, 0f);
            Shader.SetGlobalInt(IdLightCount, 0);
            Shader.DisableKeyword(PassthroughKeyword);
            keywordOn = false;
            PassthroughActive = false;
        }

        // Coming back from suspend (HoloLens: the app was left and resumed; the headset slept): the
        // socket may be dead without anyone having noticed, and the receive watchdog would take 30 s.
        // Reconnect at once; the last lighting stays up meanwhile.
        void OnApplicationPause(bool pauseStatus)
        {
            if (!pauseStatus) ReconnectAfterResume("app resumed", 0);
        }

        // Some platforms report a return only as focus; reconnect then too, but only when the stream
        // has gone quiet (focus also comes back after every system menu, with a healthy connection).
        void OnApplicationFocus(bool hasFocus)
        {
            if (hasFocus) ReconnectAfterResume("focus back", FocusSilenceSeconds);
        }

        void ReconnectAfterResume(string why, double silentFor)
        {
            if (client == null) return;
            double now = System.Diagnostics.Stopwatch.GetTimestamp() / (double)System.Diagnostics.Stopwatch.Frequency;
            if (now - lastForcedReconnect < 1.0) return; // pause(false) and focus(true) both arrive on resume
            if (silentFor > 0 && client.State != Sh9ConnectionState.Disconnected &&
                !(client.SecondsSinceLastFrame > silentFor)) return;
            lastForcedReconnect = now;
            client.ReconnectNow(why);
        }

        /// <summary>(Re)connect with the current settings.</summary>
        public void Connect()
        {
            Disconnect();
            usedUrl = serverUrl; usedToken = token; usedTokenInQuery = tokenInQuery; usedProbe = probe;
            usedMaxHz = maxHz; usedStaleAfter = staleAfterSeconds; usedEnvironment = receiveEnvironment;
            usedKeyLight = keyLightShadows;
            appliedVersion = -1; // versions restart with each client
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
                    Environment = receiveEnvironment,
                    DrawKeyLight = keyLightShadows,
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

        bool SettingsChanged()
        {
            return usedUrl != serverUrl || usedToken != token || usedTokenInQuery != tokenInQuery ||
                   usedProbe != probe || usedMaxHz != maxHz || usedStaleAfter != staleAfterSeconds ||
                   usedEnvironment != receiveEnvironment || usedKeyLight != keyLightShadows;
        }

        static Sh9LightColorSpace CurrentLightColorSpace()
        {
            if (QualitySettings.activeColorSpace != ColorSpace.Linear) return Sh9LightColorSpace.Gamma;
            return GraphicsSettings.lightsUseLinearIntensity ? Sh9LightColorSpace.LinearIntensity
                                                             : Sh9LightColorSpace.GammaIntensity;
        }

        void Update()
        {
            if (SettingsChanged()) Connect(); // changed in the inspector or by script

            string line;
            while (logQueue.TryDequeue(out line))
                if (logToConsole) Debug.Log("[SH9] " + line, this);

            Sh9Snapshot snap = client == null ? null : client.Latest;
            Quaternion rotation = ProbeRotation;
            Light light = UsableLight();
            PrepareColorTemperature();
            Sh9LightColorSpace colorSpace = CurrentLightColorSpace();
            if (snap != null)
            {
                if (snap.Version != appliedVersion || !SameRotation(rotation, appliedRotation) || intensity != appliedIntensity ||
                    light != appliedLight || colorSpace != appliedColorSpace || exposureMode != appliedMode ||
                    exposureCompensation != appliedCompensation || useColorTemperature != appliedUseTemperature ||
                    physicalCamera != appliedCamera)
                {
                    exposure = Sh9Exposure.Resolve(snap.Message, exposureMode, exposureCompensation);
                    values.Set(snap, rotation.x, rotation.y, rotation.z, rotation.w, intensity * exposure.Scale, light != null);
                    appliedKelvin = useColorTemperature ? Sh9LightTemperature.KeyLightCctK(snap.Message, snap.DrawnLight)
                                                        : double.NaN;
                    appliedVersion = snap.Version;
                    appliedRotation = rotation;
                    appliedIntensity = intensity;
                    appliedLight = light;
                    appliedColorSpace = colorSpace;
                    appliedMode = exposureMode;
                    appliedCompensation = exposureCompensation;
                    appliedUseTemperature = useColorTemperature;
                    appliedCamera = physicalCamera;
                    CopyValues();
                    ApplyLight(light, colorSpace);
                    ApplyCamera();
                    HasLighting = true;
                    LastMessage = snap.Message;
                    LastSeq = snap.Message.Seq;
                }
                LastMessageStale = snap.Message.Stale;
                AgeSeconds = (float)(snap.Message.AgeSeconds + snap.SecondsSinceReceived);
            }
            else if (!HasLighting)
            {
                // no data yet: a uniform fallback (re-evaluated so that colour/intensity edits show)
                Color linear = fallbackRadiance.linear;
                values.SetUniform(linear.r * intensity, linear.g * intensity, linear.b * intensity);
                appliedKelvin = double.NaN;
                CopyValues();
                ApplyLight(light, colorSpace);
            }
            // (a new client after a settings change has no snapshot yet: the last lighting stays)

            // Globals every frame: cheap, and survives anything else that touches them.
            Shader.SetGlobalMatrix(IdR, matrixR);
            Shader.SetGlobalMatrix(IdG, matrixG);
            Shader.SetGlobalMatrix(IdB, matrixB);
            Shader.SetGlobalFloat(IdMainLightScale, lightDriven ? 1f : 0f);
            SetLightGlobals();
            ApplyPassthrough();
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

        // Passthrough mode: the display lookup (uploaded when the fitted curve changes), the latest view's
        // exposure · white balance · 2^compensation, and the keyword; anything else switches the keyword off.
        void ApplyPassthrough()
        {
            Sh9PassthroughState state = passthrough;
            Sh9PassthroughCamera camera = state == null ? null : state.Camera;
            PassthroughActive = exposureMode == Sh9ExposureMode.Passthrough && camera != null &&
                                state.Gain(exposureCompensation, passthroughGain);
            if (!PassthroughActive)
            {
                if (keywordOn) Shader.DisableKeyword(PassthroughKeyword);
                keywordOn = false;
                return;
            }
            if (camera != uploadedCamera)
            {
                if (passthroughLut == null)
                {
                    passthroughLut = new Texture2D(Sh9PassthroughCamera.LutSize, 1, TextureFormat.RGBAFloat, false, true);
                    passthroughLut.filterMode = FilterMode.Bilinear;
                    passthroughLut.wrapMode = TextureWrapMode.Clamp;
                }
                float[] lut = camera.Lut;
                for (int j = 0; j < lutColors.Length; j++)
                    lutColors[j] = new Color(lut[4 * j], lut[4 * j + 1], lut[4 * j + 2], 1f);
                passthroughLut.SetPixels(lutColors);
                passthroughLut.Apply(false);
                uploadedCamera = camera;
            }
            Shader.SetGlobalTexture(IdPassthroughLut, passthroughLut);
            Shader.SetGlobalVector(IdPassthroughGain, new Vector4((float)passthroughGain[0], (float)passthroughGain[1],
                                                                   (float)passthroughGain[2], 0f));
            Shader.SetGlobalVector(IdPassthroughRange, new Vector4((float)camera.Log2Lo,
                                                                    (float)(1.0 / (camera.Log2Hi - camera.Log2Lo)),
                                                                    (float)camera.ToeScale, 0f));
            Shader.EnableKeyword(PassthroughKeyword);
            keywordOn = true;
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

        // The assigned light if it can be driven (a Directional Light); null otherwise, after saying why once.
        Light UsableLight()
        {
            Light light = directionalLight;
            if (light == null)
            {
                if (savedLight != null) RestoreLight();
                return null;
            }
            if (light.type != LightType.Directional)
            {
                if (savedLight != light)
                {
                    RestoreLight();
                    savedLight = light; // remembered only so that the error is said once
                    lightDriven = false;
                    Debug.LogError("[SH9] Directional Light: \"" + light.name + "\" is a " + light.type +
                                   " light; assign a Directional light (the server's lights are at infinity)", this);
                }
                return null;
            }
            if (savedLight != light)
            {
                RestoreLight();
                savedLight = light;
                savedLightEnabled = light.enabled;
                savedLightColor = light.color;
                savedLightIntensity = light.intensity;
                savedLightRotation = light.transform.rotation;
                savedLightColorTemperature = light.useColorTemperature;
                savedLightTemperature = light.colorTemperature;
                savedLightShadows = light.shadows;
                savedLightShadowStrength = light.shadowStrength;
                WarnAboutOtherDirectionalLights(light);
            }
            return light;
        }

        // Built-in forward and URP shade with one main directional light (URP: RenderSettings.sun or the
        // brightest): another enabled directional light can take that place from the driven one.
        void WarnAboutOtherDirectionalLights(Light driven)
        {
            foreach (Light other in FindObjectsOfType<Light>())
            {
                if (other != driven && other.enabled && other.type == LightType.Directional)
                    Debug.LogWarning("[SH9] another enabled Directional Light (\"" + other.name + "\") may become the " +
                                     "main light instead of \"" + driven.name + "\": disable it or set the driven one " +
                                     "as Sun Source (Lighting window)", this);
            }
        }

        // The message's lights as the shaders' light globals (sh9_lights.hlsl) while a Directional Light is
        // driven, none otherwise: slot 0 the drawn light, then the others (also folded into the SH9 globals as
        // their SH9 projections, which the shadow catchers take out to shadow each by the occluder sphere), with
        // each one's angular radius in radians.
        void SetLightGlobals()
        {
            double[] d = values.LightDirections, e = values.LightIrradiances, a = values.LightAngularRadiiDeg;
            for (int i = 0; i < 4; i++)
            {
                lightDirections[i] = new Vector4((float)d[3 * i], (float)d[3 * i + 1], (float)d[3 * i + 2], 0f);
                lightIrradiances[i] = new Vector4((float)e[3 * i], (float)e[3 * i + 1], (float)e[3 * i + 2], 0f);
            }
            const double toRad = Math.PI / 180;
            Shader.SetGlobalInt(IdLightCount, lightDriven ? values.LightCount : 0);
            Shader.SetGlobalVectorArray(IdLightDirection, lightDirections);
            Shader.SetGlobalVectorArray(IdLightIrradiance, lightIrradiances);
            Shader.SetGlobalVector(IdLightAngularRadius, new Vector4((float)(a[0] * toRad), (float)(a[1] * toRad),
                                                                     (float)(a[2] * toRad), (float)(a[3] * toRad)));
        }

        // Show the drawn light (values.LightActive) on the driven light, or switch that light off.
        void ApplyLight(Light light, Sh9LightColorSpace colorSpace)
        {
            lightDriven = light != null && values.LightActive;
            if (light == null) return;
            if (!lightDriven)
            {
                light.enabled = false; // the SH9 carries all of the light now
                return;
            }
            double[] d = values.LightDirection, e = values.LightIrradiance;
            // a directional light shines along its transform.forward: away from the light
            Sh9Math.LookRotation(-d[0], -d[1], -d[2], lightRotation);
            light.transform.rotation = new Quaternion((float)lightRotation[0], (float)lightRotation[1],
                                                      (float)lightRotation[2], (float)lightRotation[3]);
            // Built-in/URP Lambert is albedo × light × N·L with no 1/π; ours is ρE/π: give it E/π. HDRP's
            // has the 1/π: give it E, lux (LightFactor).
            double f = exposure.LightFactor;
            Color kelvinRgb = Color.white;
            bool temperature = !double.IsNaN(appliedKelvin);
            if (temperature) kelvinRgb = Mathf.CorrelatedColorTemperatureToRGB((float)appliedKelvin);
            temperature = Sh9LightTemperature.LightColor(e[0] * f, e[1] * f, e[2] * f, colorSpace, appliedKelvin,
                                                         kelvinRgb.r, kelvinRgb.g, kelvinRgb.b, lightColor);
            if (!temperature) appliedKelvin = double.NaN; // not shown as a temperature (gamma space, or none)
            light.useColorTemperature = temperature;
            if (temperature) light.colorTemperature = (float)appliedKelvin;
            light.color = new Color((float)lightColor[0], (float)lightColor[1], (float)lightColor[2], 1f);
            light.intensity = (float)lightColor[3];
            if (keyLightShadows)
            {
                light.shadows = Sh9Shadows.ShadowType(values.LightAngularRadiusDeg) == Sh9ShadowType.Soft
                    ? LightShadows.Soft : LightShadows.Hard;
                light.shadowStrength = 1f; // the catcher's ratio assumes the key light fully blocked in the umbra
            }
            else
            {
                light.shadows = savedLightShadows;
                light.shadowStrength = savedLightShadowStrength;
            }
            light.enabled = true;
        }

        void RestoreLight()
        {
            Light light = savedLight;
            savedLight = null;
            lightDriven = false;
            appliedLight = null;
            if (light == null || light.type != LightType.Directional) return;
            light.enabled = savedLightEnabled;
            light.color = savedLightColor;
            light.intensity = savedLightIntensity;
            light.transform.rotation = savedLightRotation;
            light.useColorTemperature = savedLightColorTemperature;
            light.colorTemperature = savedLightTemperature;
            light.shadows = savedLightShadows;
            light.shadowStrength = savedLightShadowStrength;
        }

        // Unity shows Light.colorTemperature only in the linear colour space with lightsUseLinearIntensity and
        // lightsUseColorTemperature on (URP and HDRP turn both on; the built-in pipeline does not): turn them on
        // while Use Color Temperature is, and put them back after.
        void PrepareColorTemperature()
        {
            if (!useColorTemperature || directionalLight == null) // nothing to colour: leave the project alone
            {
                RestoreGraphicsSettings();
                return;
            }
            if (QualitySettings.activeColorSpace != ColorSpace.Linear)
            {
                if (!warnedGammaTemperature && logToConsole)
                    Debug.LogWarning("[SH9] Use Color Temperature needs the linear colour space: the light keeps its RGB colour", this);
                warnedGammaTemperature = true;
                return;
            }
            if (GraphicsSettings.lightsUseLinearIntensity && GraphicsSettings.lightsUseColorTemperature) return;
            if (!changedGraphicsSettings)
            {
                savedLinearIntensity = GraphicsSettings.lightsUseLinearIntensity;
                savedUseTemperature = GraphicsSettings.lightsUseColorTemperature;
                changedGraphicsSettings = true;
                if (logToConsole)
                    Debug.LogWarning("[SH9] Use Color Temperature: GraphicsSettings.lightsUseLinearIntensity and " +
                                     "lightsUseColorTemperature turned on (every light's intensity is then linear)", this);
            }
            GraphicsSettings.lightsUseLinearIntensity = true;
            GraphicsSettings.lightsUseColorTemperature = true;
        }

        void RestoreGraphicsSettings()
        {
            if (!changedGraphicsSettings) return;
            GraphicsSettings.lightsUseLinearIntensity = savedLinearIntensity;
            GraphicsSettings.lightsUseColorTemperature = savedUseTemperature;
            changedGraphicsSettings = false;
        }

        // Physical Camera mode: the camera's shutter speed gives the room's EV100 at its own aperture and ISO
        // (Camera.aperture/iso/shutterSpeed are Unity 2022.2's; before, read CameraEv100).
        void ApplyCamera()
        {
#if UNITY_2022_2_OR_NEWER
            Camera camera = exposureMode == Sh9ExposureMode.PhysicalCamera ? physicalCamera : null;
            if (camera != savedCamera) RestoreCamera();
            if (camera == null || !exposure.Applied) return;
            if (savedCamera == null)
            {
                savedCamera = camera;
                savedShutterSpeed = camera.shutterSpeed;
            }
            double t = Sh9Exposure.ShutterSeconds(exposure.CameraEv100, camera.aperture, camera.iso);
            if (t > 0) camera.shutterSpeed = (float)t;
#endif
        }

        void RestoreCamera()
        {
#if UNITY_2022_2_OR_NEWER
            Camera camera = savedCamera;
            savedCamera = null;
            if (camera != null) camera.shutterSpeed = savedShutterSpeed;
#endif
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
