// SH9 maths on the client (plain C#, no UnityEngine). Conventions: DESIGN.md §1, §2, §7.
//
// Layouts used throughout:
//  * wire coefficients: double[27], index 3*i + c (coefficient i = L00, L1-1, L10, L11, L2-2,
//    L2-1, L20, L21, L22; channel c = r, g, b);
//  * matrices: double[48], index 16*c + 4*row + col (M_r, M_g, M_b, row-major, symmetric);
//  * Unity ambient probe: double[27], index 9*c + i, the memory layout of
//    UnityEngine.Rendering.SphericalHarmonicsL2 (sh[rgb, coefficient], UnityCsReference
//    Runtime/Export/Math/SphericalHarmonicsL2.bindings.cs: idx = rgb * 9 + coefficient);
//  * 3x3 rotations: double[9], row-major, acting on column vectors (v' = R v).
using System;

namespace Shlight.Lighting
{
    public static class Sh9Math
    {
        // Ramamoorthi & Hanrahan 2001, eq. 12 (DESIGN.md §2).
        public const double C1 = 0.429043, C2 = 0.511664, C3 = 0.743125, C4 = 0.886227, C5 = 0.247708;

        /// <summary>
        /// Factors that turn raw radiance SH projections L_lm (this project's basis, no
        /// Condon-Shortley phase) into the values Unity's SphericalHarmonicsL2 stores:
        /// basis constant × Â_l / π, i.e. |k| of HDRP's UndoCosineRescaling
        /// (1/2·sqrt(1/π), 1/3·sqrt(3/π), 1/8·sqrt(15/π), 1/16·sqrt(5/π), 1/16·sqrt(15/π)).
        /// Unity's table carries Condon-Shortley signs on m = ±1 together with a basis that has the
        /// same signs; the two cancel, so in our basis every factor is positive (verified below by
        /// evaluating UnityCG.cginc's ShadeSH9 on the result).
        /// </summary>
        public static readonly double[] UnityAmbientFactors =
        {
            0.28209479177387814, // L00 : 1/2  sqrt(1/pi)           = Y00 · π/π
            0.32573500793527995, // L1-1: 1/3  sqrt(3/pi)           = 0.488603 · (2π/3)/π
            0.32573500793527995, // L10
            0.32573500793527995, // L11
            0.27313710764801977, // L2-2: 1/8  sqrt(15/pi)          = 1.092548 · (π/4)/π
            0.27313710764801977, // L2-1
            0.07884789131313000, // L20 : 1/16 sqrt(5/pi)           = 0.315392 · (π/4)/π
            0.27313710764801977, // L21
            0.13656855382400988, // L22 : 1/16 sqrt(15/pi)          = 0.546274 · (π/4)/π
        };

        /// <summary>Wire coefficient indices that change sign under z → -z (L10, L2-1, L21).</summary>
        static readonly bool[] ZOdd = { false, false, true, false, false, true, false, true, false };

        // ---- matrices ---------------------------------------------------------------------

        /// <summary>The three 4×4 irradiance matrices from 27 wire coefficients (any frame).</summary>
        public static double[] MatricesFromCoefficients(double[] coefficients)
        {
            Check(coefficients, 27, "coefficients");
            var m = new double[48];
            for (int c = 0; c < 3; c++)
            {
                double L00 = coefficients[c], L1m1 = coefficients[3 + c], L10 = coefficients[6 + c],
                       L11 = coefficients[9 + c], L2m2 = coefficients[12 + c], L2m1 = coefficients[15 + c],
                       L20 = coefficients[18 + c], L21 = coefficients[21 + c], L22 = coefficients[24 + c];
                int o = 16 * c;
                m[o + 0] = C1 * L22; m[o + 1] = C1 * L2m2; m[o + 2] = C1 * L21; m[o + 3] = C2 * L11;
                m[o + 4] = C1 * L2m2; m[o + 5] = -C1 * L22; m[o + 6] = C1 * L2m1; m[o + 7] = C2 * L1m1;
                m[o + 8] = C1 * L21; m[o + 9] = C1 * L2m1; m[o + 10] = C3 * L20; m[o + 11] = C2 * L10;
                m[o + 12] = C2 * L11; m[o + 13] = C2 * L1m1; m[o + 14] = C2 * L10; m[o + 15] = C4 * L00 - C5 * L20;
            }
            return m;
        }

        /// <summary>E(n) = [n,1]ᵀ M_c [n,1] for channel c (not clamped).</summary>
        public static double Irradiance(double[] matrices, int channel, double x, double y, double z)
        {
            int o = 16 * channel;
            double[] v = { x, y, z, 1.0 };
            double e = 0;
            for (int i = 0; i < 4; i++)
            {
                double row = 0;
                for (int j = 0; j < 4; j++) row += matrices[o + 4 * i + j] * v[j];
                e += v[i] * row;
            }
            return e;
        }

        /// <summary>Irradiance RGB at a normal (not clamped).</summary>
        public static double[] Irradiance(double[] matrices, double x, double y, double z)
        {
            return new[] { Irradiance(matrices, 0, x, y, z), Irradiance(matrices, 1, x, y, z),
                           Irradiance(matrices, 2, x, y, z) };
        }

        /// <summary>
        /// Right-handed wire frame → Unity's left-handed frame, (x, y, z) → (x, y, -z):
        /// M_unity = S M S with S = diag(1, 1, -1, 1), so that E_unity(S n) = E(n).
        /// </summary>
        public static double[] MatricesToUnity(double[] matrices)
        {
            Check(matrices, 48, "matrices");
            var m = (double[])matrices.Clone();
            for (int c = 0; c < 3; c++)
            {
                for (int i = 0; i < 4; i++)
                {
                    if (i == 2) continue;
                    m[16 * c + 4 * i + 2] = -m[16 * c + 4 * i + 2];
                    m[16 * c + 4 * 2 + i] = -m[16 * c + 4 * 2 + i];
                }
            }
            return m;
        }

        /// <summary>Wire coefficients → the same environment in Unity's frame (z-odd ones negated).</summary>
        public static double[] CoefficientsToUnity(double[] coefficients)
        {
            Check(coefficients, 27, "coefficients");
            var l = (double[])coefficients.Clone();
            for (int i = 0; i < 9; i++)
                if (ZOdd[i]) for (int c = 0; c < 3; c++) l[3 * i + c] = -l[3 * i + c];
            return l;
        }

        /// <summary>S R S: the right-handed rotation R expressed in Unity's frame.</summary>
        public static double[] RotationToUnity(double[] rotation)
        {
            Check(rotation, 9, "rotation");
            var r = (double[])rotation.Clone();
            // flip row 2 and column 2 (the (2,2) entry is flipped twice)
            r[2] = -r[2]; r[5] = -r[5]; r[6] = -r[6]; r[7] = -r[7];
            return r;
        }

        /// <summary>
        /// Rotation matrix of a Unity quaternion (x, y, z, w), the same matrix Unity's
        /// Quaternion * Vector3 applies (UnityCsReference Runtime/Export/Math/Quaternion.cs).
        /// The quaternion is normalised first.
        /// </summary>
        public static double[] QuaternionToMatrix(double qx, double qy, double qz, double qw)
        {
            double n = Math.Sqrt(qx * qx + qy * qy + qz * qz + qw * qw);
            if (!(n > 1e-12)) return new double[] { 1, 0, 0, 0, 1, 0, 0, 0, 1 };
            qx /= n; qy /= n; qz /= n; qw /= n;
            double x = qx * 2, y = qy * 2, z = qz * 2;
            double xx = qx * x, yy = qy * y, zz = qz * z, xy = qx * y, xz = qx * z, yz = qy * z;
            double wx = qw * x, wy = qw * y, wz = qw * z;
            return new[]
            {
                1 - (yy + zz), xy - wz, xz + wy,
                xy + wz, 1 - (xx + zz), yz - wx,
                xz - wy, yz + wx, 1 - (xx + yy),
            };
        }

        /// <summary>Rotate a direction: R v.</summary>
        public static double[] Rotate(double[] rotation, double x, double y, double z)
        {
            return new[]
            {
                rotation[0] * x + rotation[1] * y + rotation[2] * z,
                rotation[3] * x + rotation[4] * y + rotation[5] * z,
                rotation[6] * x + rotation[7] * y + rotation[8] * z,
            };
        }

        /// <summary>
        /// Re-orient the environment: M' = R̃ M R̃ᵀ with R̃ = diag(R, 1), so that
        /// E'(R n) = E(n): what the probe saw along n is now seen along R n.
        /// For a probe attached to a Unity transform, R is the matrix of transform.rotation
        /// (probe-local → world), with M already in Unity's frame.
        /// </summary>
        public static double[] RotateMatrices(double[] matrices, double[] rotation)
        {
            Check(matrices, 48, "matrices");
            Check(rotation, 9, "rotation");
            var rt = new double[16];
            for (int i = 0; i < 3; i++)
                for (int j = 0; j < 3; j++) rt[4 * i + j] = rotation[3 * i + j];
            rt[15] = 1;
            var result = new double[48];
            var tmp = new double[16];
            for (int c = 0; c < 3; c++)
            {
                int o = 16 * c;
                // tmp = R̃ M
                for (int i = 0; i < 4; i++)
                    for (int j = 0; j < 4; j++)
                    {
                        double s = 0;
                        for (int k = 0; k < 4; k++) s += rt[4 * i + k] * matrices[o + 4 * k + j];
                        tmp[4 * i + j] = s;
                    }
                // result = tmp R̃ᵀ
                for (int i = 0; i < 4; i++)
                    for (int j = 0; j < 4; j++)
                    {
                        double s = 0;
                        for (int k = 0; k < 4; k++) s += tmp[4 * i + k] * rt[4 * j + k];
                        result[o + 4 * i + j] = s;
                    }
            }
            return result;
        }

        /// <summary>Multiply every entry by <paramref name="scale"/> (intensity multiplier).</summary>
        public static double[] Scale(double[] values, double scale)
        {
            var r = new double[values.Length];
            for (int i = 0; i < values.Length; i++) r[i] = values[i] * scale;
            return r;
        }

        // ---- Unity ambient probe (SphericalHarmonicsL2) -----------------------------------

        /// <summary>
        /// Unity SphericalHarmonicsL2 values (layout 9*c + i) from coefficients that are already
        /// in Unity's frame (<see cref="CoefficientsToUnity"/>): sh[c, i] = k_i · L_i.
        /// Built-in shaders then compute ShadeSH9(n) = E(n)/π.
        /// </summary>
        public static double[] AmbientProbeFromCoefficients(double[] unityCoefficients)
        {
            Check(unityCoefficients, 27, "coefficients");
            var sh = new double[27];
            for (int c = 0; c < 3; c++)
                for (int i = 0; i < 9; i++)
                    sh[9 * c + i] = UnityAmbientFactors[i] * unityCoefficients[3 * i + c];
            return sh;
        }

        /// <summary>
        /// Unity SphericalHarmonicsL2 values (layout 9*c + i) from irradiance matrices in Unity's
        /// frame, after any rotation and scaling. Exact: on unit normals ñᵀMñ is a polynomial of
        /// degree 2, and x²+y²+z² = 1 lets it be rewritten in ShadeSH9's polynomial basis
        /// {1, y, z, x, xy, yz, 3z²-1, xz, x²-y²}; each term divided by π.
        /// Equals <see cref="AmbientProbeFromCoefficients"/> for matrices built from coefficients.
        /// </summary>
        public static double[] AmbientProbeFromMatrices(double[] unityMatrices)
        {
            Check(unityMatrices, 48, "matrices");
            var sh = new double[27];
            double invPi = 1.0 / Math.PI;
            for (int c = 0; c < 3; c++)
            {
                int o = 16 * c;
                double m00 = unityMatrices[o + 0], m11 = unityMatrices[o + 5], m22 = unityMatrices[o + 10];
                double m33 = unityMatrices[o + 15];
                // symmetric part of the off-diagonal (tolerates a slightly asymmetric input)
                double m01 = 0.5 * (unityMatrices[o + 1] + unityMatrices[o + 4]);
                double m02 = 0.5 * (unityMatrices[o + 2] + unityMatrices[o + 8]);
                double m12 = 0.5 * (unityMatrices[o + 6] + unityMatrices[o + 9]);
                double m03 = 0.5 * (unityMatrices[o + 3] + unityMatrices[o + 12]);
                double m13 = 0.5 * (unityMatrices[o + 7] + unityMatrices[o + 13]);
                double m23 = 0.5 * (unityMatrices[o + 11] + unityMatrices[o + 14]);
                // m00 x² + m11 y² + m22 z² = a (x²-y²) + b (3z²-1) + const  on the unit sphere
                double a = 0.5 * (m00 - m11);
                double half = 0.5 * (m00 + m11);
                double b = (m22 - half) / 3.0;
                double constant = half + b + m33;
                int s = 9 * c;
                sh[s + 0] = constant * invPi;      // 1
                sh[s + 1] = 2 * m13 * invPi;       // y
                sh[s + 2] = 2 * m23 * invPi;       // z
                sh[s + 3] = 2 * m03 * invPi;       // x
                sh[s + 4] = 2 * m01 * invPi;       // xy
                sh[s + 5] = 2 * m12 * invPi;       // yz
                sh[s + 6] = b * invPi;             // 3z² - 1
                sh[s + 7] = 2 * m02 * invPi;       // xz
                sh[s + 8] = a * invPi;             // x² - y²
            }
            return sh;
        }

        /// <summary>
        /// The seven float4 shader constants Unity derives from a SphericalHarmonicsL2
        /// (unity_SHAr, unity_SHAg, unity_SHAb, unity_SHBr, unity_SHBg, unity_SHBb, unity_SHC),
        /// as HDRP's SphericalHarmonicMath.PackCoefficients packs them:
        /// SHA = (c3, c1, c2, c0 - c6), SHB = (c4, c5, 3 c6, c7), SHC = (c8.r, c8.g, c8.b, 1).
        /// Returned as double[28], four per constant.
        /// </summary>
        public static double[] PackUnityShaderConstants(double[] probe)
        {
            Check(probe, 27, "probe");
            var k = new double[28];
            for (int c = 0; c < 3; c++)
            {
                int s = 9 * c;
                k[4 * c + 0] = probe[s + 3];
                k[4 * c + 1] = probe[s + 1];
                k[4 * c + 2] = probe[s + 2];
                k[4 * c + 3] = probe[s + 0] - probe[s + 6];
                k[12 + 4 * c + 0] = probe[s + 4];
                k[12 + 4 * c + 1] = probe[s + 5];
                k[12 + 4 * c + 2] = probe[s + 6] * 3.0;
                k[12 + 4 * c + 3] = probe[s + 7];
                k[24 + c] = probe[s + 8];
            }
            k[27] = 1.0;
            return k;
        }

        /// <summary>
        /// UnityCG.cginc's ShadeSH9 (SHEvalLinearL0L1 + SHEvalLinearL2), linear colour space,
        /// evaluated on packed constants at the normal (x, y, z). Returns RGB.
        /// </summary>
        public static double[] ShadeSH9(double[] packed, double x, double y, double z)
        {
            Check(packed, 28, "packed constants");
            var rgb = new double[3];
            double[] vB = { x * y, y * z, z * z, z * x };        // normal.xyzz * normal.yzzx
            double vC = x * x - y * y;
            for (int c = 0; c < 3; c++)
            {
                int a = 4 * c, b = 12 + 4 * c;
                double x1 = packed[a] * x + packed[a + 1] * y + packed[a + 2] * z + packed[a + 3] * 1.0;
                double x2 = packed[b] * vB[0] + packed[b + 1] * vB[1] + packed[b + 2] * vB[2] + packed[b + 3] * vB[3];
                double x3 = packed[24 + c] * vC;
                rgb[c] = x1 + x2 + x3;
            }
            return rgb;
        }

        static void Check(double[] a, int n, string what)
        {
            if (a == null) throw new ArgumentNullException(what);
            if (a.Length != n) throw new ArgumentException(what + " must have " + n + " values, got " + a.Length);
        }
    }
}
