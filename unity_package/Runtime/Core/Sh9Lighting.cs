// From a received message to the values a renderer uploads (plain C#, no UnityEngine).
// The MonoBehaviour and the Mono test client both go through this class, so what the tests
// check is what Unity gets.
using System;

namespace Shlight.Lighting
{
    /// <summary>One accepted "sh9" message, already converted to Unity's frame (immutable).
    /// Built on the receive thread, where allocating is fine; nothing here runs per frame.</summary>
    public sealed class Sh9Snapshot
    {
        /// <summary>The message as received (right-handed wire frame).</summary>
        public readonly Sh9Message Message;
        /// <summary>The three matrices in Unity's left-handed frame, before any rotation or intensity.</summary>
        public readonly double[] UnityMatrices;
        /// <summary>Coefficients in Unity's frame (z-odd terms negated), wire layout.</summary>
        public readonly double[] UnityCoefficients;
        /// <summary>
        /// With <see cref="Sh9Message.HasLightSplit"/>: the ambient matrices in Unity's frame, plus the
        /// order-2 part of every light but the drawn one (<see cref="DrawnLight"/>: only it is drawn as a
        /// Unity light, the others stay in the SH9 so that nothing is lost). Null otherwise.
        /// </summary>
        public readonly double[] UnityAmbientMatrices;
        /// <summary>Which of the message's lights is drawn as a Unity light: the first (0), or the key light
        /// (<see cref="Sh9Shadows.KeyLightIndex"/>) when the client is asked to draw that one.</summary>
        public readonly int DrawnLight;
        /// <summary>Direction toward the drawn light in Unity's frame (x, y, -z); null without lights.</summary>
        public readonly double[] UnityLightDirection;
        /// <summary>RGB irradiance of the drawn light on a surface facing it; null without lights.</summary>
        public readonly double[] LightIrradiance;
        /// <summary>Angular radius of the drawn light (degrees; 0 when the server sends none, or without lights).</summary>
        public readonly double LightAngularRadiusDeg;
        /// <summary>When it arrived, in <see cref="System.Diagnostics.Stopwatch"/> ticks.</summary>
        public readonly long ReceivedTimestamp;
        /// <summary>1, 2, 3, ... per accepted message of this client (changes when new data arrives).</summary>
        public readonly long Version;

        public Sh9Snapshot(Sh9Message message, long receivedTimestamp, long version)
            : this(message, receivedTimestamp, version, 0)
        {
        }

        /// <summary>As the other constructor, drawing light <paramref name="drawnLight"/> of the message
        /// (out of range: the first).</summary>
        public Sh9Snapshot(Sh9Message message, long receivedTimestamp, long version, int drawnLight)
        {
            if (message == null) throw new ArgumentNullException("message");
            Message = message;
            UnityMatrices = Sh9Math.MatricesToUnity(message.Matrices);
            UnityCoefficients = Sh9Math.CoefficientsToUnity(message.Coefficients);
            if (message.HasLightSplit)
            {
                int p = drawnLight >= 0 && drawnLight < message.Lights ? drawnLight : 0;
                DrawnLight = p;
                double[] d = message.LightDirections, e = message.LightIrradiance;
                UnityLightDirection = new[] { d[3 * p], d[3 * p + 1], -d[3 * p + 2] };
                LightIrradiance = new[] { e[3 * p], e[3 * p + 1], e[3 * p + 2] };
                if (message.LightAngularRadiusDeg.Length == message.Lights)
                    LightAngularRadiusDeg = message.LightAngularRadiusDeg[p];
                double[] ambient = message.AmbientMatrices;
                if (message.Lights > 1)
                {
                    var extra = new double[27];
                    for (int i = 0; i < message.Lights; i++)
                        if (i != p)
                            Sh9Math.AddDirectionalLight(extra, d[3 * i], d[3 * i + 1], d[3 * i + 2],
                                                    e[3 * i], e[3 * i + 1], e[3 * i + 2]);
                    double[] em = Sh9Math.MatricesFromCoefficients(extra);
                    ambient = (double[])ambient.Clone();
                    for (int i = 0; i < 48; i++) ambient[i] += em[i];
                }
                UnityAmbientMatrices = Sh9Math.MatricesToUnity(ambient);
            }
            ReceivedTimestamp = receivedTimestamp;
            Version = version;
        }

        /// <summary>Seconds since it arrived.</summary>
        public double SecondsSinceReceived
        {
            get
            {
                long dt = System.Diagnostics.Stopwatch.GetTimestamp() - ReceivedTimestamp;
                return dt / (double)System.Diagnostics.Stopwatch.Frequency;
            }
        }
    }

    /// <summary>
    /// Unity-frame lighting for one orientation and intensity: what gets uploaded. Every Set*
    /// method works in preallocated buffers: calling it every frame allocates nothing.
    /// </summary>
    public sealed class Sh9LightingValues
    {
        /// <summary>M_r, M_g, M_b (48 floats, row-major) for _SHIrradianceR/G/B, Unity world frame.
        /// The ambient part only while <see cref="LightActive"/> (the light is drawn separately).</summary>
        public readonly float[] Matrices = new float[48];
        /// <summary>SphericalHarmonicsL2 values, layout sh[rgb, i] = [9 * rgb + i]; from the same
        /// matrices as <see cref="Matrices"/>.</summary>
        public readonly float[] AmbientProbe = new float[27];
        /// <summary>True when the first light of the message is to be drawn as a directional light.</summary>
        public bool LightActive { get; private set; }
        /// <summary>Unit direction toward the light, Unity world frame (rotation applied).</summary>
        public readonly double[] LightDirection = new double[3];
        /// <summary>RGB irradiance of the light on a surface facing it (intensity applied).</summary>
        public readonly double[] LightIrradiance = new double[3];
        /// <summary>Angular radius of the drawn light, degrees (0: none sent, or no light).</summary>
        public double LightAngularRadiusDeg { get; private set; }
        /// <summary>How many of the message's lights the shaders' light slots hold (0 unless <see cref="LightActive"/>;
        /// at most <see cref="MaxShaderLights"/>): slot 0 the drawn light, then the others in the message's order.
        /// Those others are also in <see cref="Matrices"/> as their SH9 projections (the ambient probe must keep them);
        /// the shadow catchers take them out again to shadow each one (sh9_lights.hlsl SHShadowRatioOfSphere).</summary>
        public int LightCount { get; private set; }
        /// <summary>Shader light slots (SH_MAX_LIGHTS in sh9_lights.hlsl).</summary>
        public const int MaxShaderLights = 4;
        /// <summary>Per slot: the unit direction toward the light (x, y, z), Unity world frame, rotation applied.</summary>
        public readonly double[] LightDirections = new double[3 * MaxShaderLights];
        /// <summary>Per slot: its RGB irradiance on a surface facing it (intensity applied).</summary>
        public readonly double[] LightIrradiances = new double[3 * MaxShaderLights];
        /// <summary>Per slot: its angular radius, degrees (0: none sent).</summary>
        public readonly double[] LightAngularRadiiDeg = new double[MaxShaderLights];

        readonly double[] rotation = new double[9];
        readonly double[] rotated = new double[48];
        readonly double[] scaled = new double[48];
        readonly double[] probe = new double[27];
        readonly double[] scratch = new double[48];

        /// <summary>
        /// Convert: M_world = R̃ (S M S) R̃ᵀ · intensity, ambient probe from M_world.
        /// <paramref name="unityMatrices"/>: <see cref="Sh9Snapshot.UnityMatrices"/>;
        /// <paramref name="rotation"/>: 3×3 row-major of the probe's transform.rotation (null = identity).
        /// </summary>
        public void Set(double[] unityMatrices, double[] rotation, double intensity)
        {
            LightActive = false;
            Apply(unityMatrices, rotation, intensity);
        }

        /// <summary>
        /// The snapshot for a probe whose transform.rotation is the quaternion (qx, qy, qz, qw).
        /// With <paramref name="drawLight"/> and a message that splits off lights, the matrices and
        /// ambient probe get the ambient SH9 and <see cref="LightDirection"/>/<see cref="LightIrradiance"/>
        /// the first light (so a Unity light can show it without counting it twice); otherwise they get
        /// the full SH9 and <see cref="LightActive"/> is false.
        /// </summary>
        public void Set(Sh9Snapshot snapshot, double qx, double qy, double qz, double qw, double intensity,
                        bool drawLight)
        {
            if (snapshot == null) throw new ArgumentNullException("snapshot");
            Sh9Math.QuaternionToMatrix(qx, qy, qz, qw, this.rotation);
            bool light = drawLight && snapshot.UnityAmbientMatrices != null;
            LightActive = light;
            Apply(light ? snapshot.UnityAmbientMatrices : snapshot.UnityMatrices, this.rotation, intensity);
            Array.Clear(LightDirections, 0, LightDirections.Length);
            Array.Clear(LightIrradiances, 0, LightIrradiances.Length);
            Array.Clear(LightAngularRadiiDeg, 0, LightAngularRadiiDeg.Length);
            LightCount = 0;
            if (light)
            {
                // the slots: the drawn light, then the others in the message's order
                Sh9Message m = snapshot.Message;
                double[] r = this.rotation;
                bool radii = m.LightAngularRadiusDeg.Length == m.Lights;      // else none sent: 0
                for (int k = -1; k < m.Lights && LightCount < MaxShaderLights; k++)
                {
                    int i = k < 0 ? snapshot.DrawnLight : k;
                    if (k >= 0 && i == snapshot.DrawnLight) continue;
                    double x = m.LightDirections[3 * i], y = m.LightDirections[3 * i + 1], z = -m.LightDirections[3 * i + 2];
                    int o = 3 * LightCount;
                    LightDirections[o] = r[0] * x + r[1] * y + r[2] * z;
                    LightDirections[o + 1] = r[3] * x + r[4] * y + r[5] * z;
                    LightDirections[o + 2] = r[6] * x + r[7] * y + r[8] * z;
                    for (int c = 0; c < 3; c++) LightIrradiances[o + c] = m.LightIrradiance[3 * i + c] * intensity;
                    LightAngularRadiiDeg[LightCount] = radii ? m.LightAngularRadiusDeg[i] : 0;
                    LightCount++;
                }
            }
            // the drawn light is slot 0 (all zero without a light)
            Array.Copy(LightDirections, LightDirection, 3);
            Array.Copy(LightIrradiances, LightIrradiance, 3);
            LightAngularRadiusDeg = LightAngularRadiiDeg[0];
        }

        void Apply(double[] unityMatrices, double[] rotation, double intensity)
        {
            double[] m = unityMatrices;
            if (rotation != null)
            {
                Sh9Math.RotateMatrices(m, rotation, rotated);
                m = rotated;
            }
            if (intensity != 1.0)
            {
                for (int i = 0; i < 48; i++) scaled[i] = m[i] * intensity;
                m = scaled;
            }
            Sh9Math.AmbientProbeFromMatrices(m, probe);
            for (int i = 0; i < 48; i++) Matrices[i] = (float)m[i];
            for (int i = 0; i < 27; i++) AmbientProbe[i] = (float)probe[i];
        }

        /// <summary>A uniform environment of the given linear radiance per channel: E = π·L everywhere.</summary>
        public void SetUniform(double r, double g, double b)
        {
            Array.Clear(Matrices, 0, 48);
            Array.Clear(AmbientProbe, 0, 27);
            LightActive = false;
            Matrices[15] = (float)(Math.PI * r);
            Matrices[31] = (float)(Math.PI * g);
            Matrices[47] = (float)(Math.PI * b);
            AmbientProbe[0] = (float)r;
            AmbientProbe[9] = (float)g;
            AmbientProbe[18] = (float)b;
        }

        /// <summary>E(n) RGB of the current matrices (not clamped, light not included); n in Unity world frame.</summary>
        public double[] Irradiance(double x, double y, double z)
        {
            for (int i = 0; i < 48; i++) scratch[i] = Matrices[i];
            return Sh9Math.Irradiance(scratch, x, y, z);
        }
    }
}
