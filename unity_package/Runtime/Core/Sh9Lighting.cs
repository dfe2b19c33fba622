// From a received message to the values a renderer uploads (plain C#, no UnityEngine).
// The MonoBehaviour and the Mono test client both go through this class, so what the tests
// check is what Unity gets.
using System;

namespace Shlight.Lighting
{
    /// <summary>One accepted "sh9" message, already converted to Unity's frame (immutable).</summary>
    public sealed class Sh9Snapshot
    {
        /// <summary>The message as received (right-handed wire frame).</summary>
        public readonly Sh9Message Message;
        /// <summary>The three matrices in Unity's left-handed frame, before any rotation or intensity.</summary>
        public readonly double[] UnityMatrices;
        /// <summary>Coefficients in Unity's frame (z-odd terms negated), wire layout.</summary>
        public readonly double[] UnityCoefficients;
        /// <summary>When it arrived, in <see cref="System.Diagnostics.Stopwatch"/> ticks.</summary>
        public readonly long ReceivedTimestamp;
        /// <summary>1, 2, 3, ... per accepted message of this client (changes when new data arrives).</summary>
        public readonly long Version;

        public Sh9Snapshot(Sh9Message message, long receivedTimestamp, long version)
        {
            if (message == null) throw new ArgumentNullException("message");
            Message = message;
            UnityMatrices = Sh9Math.MatricesToUnity(message.Matrices);
            UnityCoefficients = Sh9Math.CoefficientsToUnity(message.Coefficients);
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

    /// <summary>Unity-frame lighting for one orientation and intensity: what gets uploaded.</summary>
    public sealed class Sh9LightingValues
    {
        /// <summary>M_r, M_g, M_b (48 floats, row-major) for _SHIrradianceR/G/B, Unity world frame.</summary>
        public readonly float[] Matrices = new float[48];
        /// <summary>SphericalHarmonicsL2 values, layout sh[rgb, i] = [9 * rgb + i].</summary>
        public readonly float[] AmbientProbe = new float[27];

        /// <summary>
        /// Convert: M_world = R̃ (S M S) R̃ᵀ · intensity, ambient probe from M_world.
        /// <paramref name="unityMatrices"/>: <see cref="Sh9Snapshot.UnityMatrices"/>;
        /// <paramref name="rotation"/>: 3×3 row-major of the probe's transform.rotation (null = identity).
        /// </summary>
        public void Set(double[] unityMatrices, double[] rotation, double intensity)
        {
            double[] m = rotation == null ? unityMatrices : Sh9Math.RotateMatrices(unityMatrices, rotation);
            if (intensity != 1.0) m = Sh9Math.Scale(m, intensity);
            double[] sh = Sh9Math.AmbientProbeFromMatrices(m);
            for (int i = 0; i < 48; i++) Matrices[i] = (float)m[i];
            for (int i = 0; i < 27; i++) AmbientProbe[i] = (float)sh[i];
        }

        /// <summary>A uniform environment of the given linear radiance per channel: E = π·L everywhere.</summary>
        public void SetUniform(double r, double g, double b)
        {
            Array.Clear(Matrices, 0, 48);
            Array.Clear(AmbientProbe, 0, 27);
            double[] rgb = { r, g, b };
            for (int c = 0; c < 3; c++)
            {
                Matrices[16 * c + 15] = (float)(Math.PI * rgb[c]);
                AmbientProbe[9 * c] = (float)rgb[c];
            }
        }

        /// <summary>E(n) RGB of the current matrices (not clamped); n in Unity world frame.</summary>
        public double[] Irradiance(double x, double y, double z)
        {
            var m = new double[48];
            for (int i = 0; i < 48; i++) m[i] = Matrices[i];
            return Sh9Math.Irradiance(m, x, y, z);
        }
    }
}
