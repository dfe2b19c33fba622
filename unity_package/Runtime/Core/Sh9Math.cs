// SH9 maths on the client (plain C#, no UnityEngine). Conventions: docs/contract.md §1, §2, §7.
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
        // Ramamoorthi & Hanrahan 2001, eq. 12 (docs/contract.md §2).
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
            var r = new double[9];
            QuaternionToMatrix(qx, qy, qz, qw, r);
            return r;
        }

        /// <summary>As <see cref="QuaternionToMatrix(double,double,double,double)"/>, into
        /// <paramref name="result"/> (9 values; no allocation, for per-frame use).</summary>
        public static void QuaternionToMatrix(double qx, double qy, double qz, double qw, double[] result)
        {
            Check(result, 9, "result");
            double n = Math.Sqrt(qx * qx + qy * qy + qz * qz + qw * qw);
            if (!(n > 1e-12)) { qx = qy = qz = 0; qw = 1; n = 1; }
            qx /= n; qy /= n; qz /= n; qw /= n;
            double x = qx * 2, y = qy * 2, z = qz * 2;
            double xx = qx * x, yy = qy * y, zz = qz * z, xy = qx * y, xz = qx * z, yz = qy * z;
            double wx = qw * x, wy = qw * y, wz = qw * z;
            result[0] = 1 - (yy + zz); result[1] = xy - wz; result[2] = xz + wy;
            result[3] = xy + wz; result[4] = 1 - (xx + zz); result[5] = yz - wx;
            result[6] = xz - wy; result[7] = yz + wx; result[8] = 1 - (xx + yy);
        }

        /// <summary>
        /// Unit quaternion (x, y, z, w) of the rotation whose forward (R·(0,0,1), Unity's
        /// transform.forward) is <paramref name="fx"/>, <paramref name="fy"/>, <paramref name="fz"/>,
        /// with its up as close to world +Y as possible (world +X when forward is vertical): what
        /// Quaternion.LookRotation(forward) gives. Written into <paramref name="q"/> (4 values).
        /// A directional light's roll does not matter; only R·(0,0,1) is relied on.
        /// </summary>
        public static void LookRotation(double fx, double fy, double fz, double[] q)
        {
            Check(q, 4, "q");
            double n = Math.Sqrt(fx * fx + fy * fy + fz * fz);
            if (!(n > 1e-12)) { q[0] = q[1] = q[2] = 0; q[3] = 1; return; }
            fx /= n; fy /= n; fz /= n;
            double ux = 0, uy = 1, uz = 0;
            if (Math.Abs(fy) > 0.999) { ux = 1; uy = 0; }
            // right = up × forward, up' = forward × right (Unity's Vector3.Cross is the usual formula,
            // so Cross(up, forward) = right for the identity basis)
            double rx = uy * fz - uz * fy, ry = uz * fx - ux * fz, rz = ux * fy - uy * fx;
            double rn = Math.Sqrt(rx * rx + ry * ry + rz * rz);
            rx /= rn; ry /= rn; rz /= rn;
            double vx = fy * rz - fz * ry, vy = fz * rx - fx * rz, vz = fx * ry - fy * rx;
            // columns (right, up', forward): m[row, col]
            double m00 = rx, m01 = vx, m02 = fx, m10 = ry, m11 = vy, m12 = fy, m20 = rz, m21 = vz, m22 = fz;
            double tr = m00 + m11 + m22, x, y, z, w;
            if (tr > 0)
            {
                double s = Math.Sqrt(tr + 1.0) * 2;
                w = 0.25 * s; x = (m21 - m12) / s; y = (m02 - m20) / s; z = (m10 - m01) / s;
            }
            else if (m00 > m11 && m00 > m22)
            {
                double s = Math.Sqrt(1.0 + m00 - m11 - m22) * 2;
                w = (m21 - m12) / s; x = 0.25 * s; y = (m01 + m10) / s; z = (m02 + m20) / s;
            }
            else if (m11 > m22)
            {
                double s = Math.Sqrt(1.0 + m11 - m00 - m22) * 2;
                w = (m02 - m20) / s; x = (m01 + m10) / s; y = 0.25 * s; z = (m12 + m21) / s;
            }
            else
            {
                double s = Math.Sqrt(1.0 + m22 - m00 - m11) * 2;
                w = (m10 - m01) / s; x = (m02 + m20) / s; y = (m12 + m21) / s; z = 0.25 * s;
            }
            q[0] = x; q[1] = y; q[2] = z; q[3] = w;
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
            var result = new double[48];
            RotateMatrices(matrices, rotation, result);
            return result;
        }

        /// <summary>As <see cref="RotateMatrices(double[],double[])"/>, into <paramref name="result"/>
        /// (48 values, must not be <paramref name="matrices"/>; no allocation).</summary>
        public static void RotateMatrices(double[] matrices, double[] rotation, double[] result)
        {
            Check(matrices, 48, "matrices");
            Check(rotation, 9, "rotation");
            Check(result, 48, "result");
            if (ReferenceEquals(matrices, result)) throw new ArgumentException("result must not be the input");
            for (int c = 0; c < 3; c++)
            {
                int o = 16 * c;
                // result = R̃ M R̃ᵀ, R̃ = diag(R, 1): (R̃ M R̃ᵀ)_ij = Σ_kl R̃_ik M_kl R̃_jl
                for (int i = 0; i < 4; i++)
                    for (int j = 0; j < 4; j++)
                    {
                        double s = 0;
                        for (int k = 0; k < 4; k++)
                        {
                            double rik = i == 3 ? (k == 3 ? 1 : 0) : (k == 3 ? 0 : rotation[3 * i + k]);
                            if (rik == 0) continue;
                            double row = 0;
                            for (int l = 0; l < 4; l++)
                            {
                                double rjl = j == 3 ? (l == 3 ? 1 : 0) : (l == 3 ? 0 : rotation[3 * j + l]);
                                row += matrices[o + 4 * k + l] * rjl;
                            }
                            s += rik * row;
                        }
                        result[o + 4 * i + j] = s;
                    }
            }
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
            var sh = new double[27];
            AmbientProbeFromMatrices(unityMatrices, sh);
            return sh;
        }

        /// <summary>As <see cref="AmbientProbeFromMatrices(double[])"/>, into <paramref name="sh"/>
        /// (27 values; no allocation).</summary>
        public static void AmbientProbeFromMatrices(double[] unityMatrices, double[] sh)
        {
            Check(unityMatrices, 48, "matrices");
            Check(sh, 27, "sh");
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

        // ---- directional lights (docs/contract.md §10) --------------------------------------------

        /// <summary>
        /// Add a directional light to wire-layout coefficients (27, index 3*i + c): the SH9 projection
        /// of irradiance·max(0, n·d) is irradiance × Y_lm(d) in radiance units (Funk-Hecke: the clamped
        /// cosine's band-l factor is exactly Â_l), so E from the result gains the light's order-2 part.
        /// Used to fold lights that are not drawn as lights back into the ambient SH9.
        /// </summary>
        public static void AddDirectionalLight(double[] coefficients, double dx, double dy, double dz,
                                               double r, double g, double b)
        {
            Check(coefficients, 27, "coefficients");
            double[] y = {
                0.282095, 0.488603 * dy, 0.488603 * dz, 0.488603 * dx, 1.092548 * dx * dy, 1.092548 * dy * dz,
                0.315392 * (3 * dz * dz - 1), 1.092548 * dx * dz, 0.546274 * (dx * dx - dy * dy) };
            for (int i = 0; i < 9; i++)
            {
                coefficients[3 * i] += y[i] * r;
                coefficients[3 * i + 1] += y[i] * g;
                coefficients[3 * i + 2] += y[i] * b;
            }
        }

        /// <summary>sRGB-encoded → linear, the curve of UnityCG.cginc's GammaToLinearSpaceExact
        /// (piecewise sRGB below 1, pow 2.2 above).</summary>
        public static double GammaToLinearExact(double value)
        {
            if (value <= 0.04045) return value / 12.92;
            if (value < 1.0) return Math.Pow((value + 0.055) / 1.055, 2.4);
            return Math.Pow(value, 2.2);
        }

        /// <summary>Linear → sRGB-encoded, UnityCG.cginc's LinearToGammaSpaceExact (the inverse of
        /// <see cref="GammaToLinearExact"/>).</summary>
        public static double LinearToGammaExact(double value)
        {
            if (value <= 0.0) return 0.0;
            if (value <= 0.0031308) return 12.92 * value;
            if (value < 1.0) return 1.055 * Math.Pow(value, 0.4166667) - 0.055;
            return Math.Pow(value, 0.45454545);
        }

        /// <summary>
        /// Light.color (sRGB-encoded, each channel in [0, 1]) and Light.intensity for a Unity light
        /// whose shaders must see the linear colour <paramref name="r"/>, <paramref name="g"/>,
        /// <paramref name="b"/> (for our use: light irradiance / π, so that Unity's Lambert,
        /// albedo × light colour × N·L with no 1/π, shows ρE/π like docs/contract.md §2).
        /// How Unity turns (color, intensity) into the shader's colour (GraphicsSettings.lightsUseLinearIntensity
        /// documentation): <see cref="Sh9LightColorSpace.LinearIntensity"/>: color.linear × intensity;
        /// <see cref="Sh9LightColorSpace.GammaIntensity"/>: (color × intensity) converted to linear;
        /// <see cref="Sh9LightColorSpace.Gamma"/> (gamma colour space): color × intensity, used as is by
        /// shaders that light in gamma space. Result: rgbi = (color.r, color.g, color.b, intensity).
        /// </summary>
        public static void LightColorFromLinear(double r, double g, double b, Sh9LightColorSpace space, double[] rgbi)
        {
            Check(rgbi, 4, "rgbi");
            r = Math.Max(0, r); g = Math.Max(0, g); b = Math.Max(0, b);
            if (space != Sh9LightColorSpace.LinearIntensity)
            {
                // the product color × intensity is what gets linearised (or shaded in gamma): encode it
                r = LinearToGammaExact(r); g = LinearToGammaExact(g); b = LinearToGammaExact(b);
            }
            double intensity = Math.Max(r, Math.Max(g, b));
            if (!(intensity > 0)) { rgbi[0] = rgbi[1] = rgbi[2] = rgbi[3] = 0; return; }
            r /= intensity; g /= intensity; b /= intensity;
            if (space == Sh9LightColorSpace.LinearIntensity)
            {
                // color.linear must be the normalised linear colour: store its sRGB encoding
                r = LinearToGammaExact(r); g = LinearToGammaExact(g); b = LinearToGammaExact(b);
            }
            rgbi[0] = r; rgbi[1] = g; rgbi[2] = b; rgbi[3] = intensity;
        }

        static void Check(double[] a, int n, string what)
        {
            if (a == null) throw new ArgumentNullException(what);
            if (a.Length != n) throw new ArgumentException(what + " must have " + n + " values, got " + a.Length);
        }
    }
}

    /// <summary>How Unity turns a Light's colour and intensity into the colour its shaders see.</summary>
    public enum Sh9LightColorSpace
    {
        /// <summary>Linear colour space with GraphicsSettings.lightsUseLinearIntensity on (URP's
        /// setting in linear projects): color.linear × intensity.</summary>
        LinearIntensity = 0,
        /// <summary>Linear colour space with lightsUseLinearIntensity off (the built-in pipeline's
        /// default): (color × intensity) converted to linear.</summary>
        GammaIntensity = 1,
        /// <summary>Gamma colour space: color × intensity, in gamma; Unity's own shaders then light in
        /// gamma and no light setting reproduces ρE/π for every albedo (SH9 Diffuse linearises it).</summary>
        Gamma = 2,
    }

