// The provider's cube (wire frame, its own mip ↔ roughness chain) baked into the texels of a
// Unity Cubemap (Unity's left-handed frame, Unity's mip ↔ roughness curve). Plain C#, no
// UnityEngine: the component copies Data into the Cubemap's levels and faces.
//
// Unity's shaders read a reflection cube at lod = perceptualRoughnessToMipmapLevel(ρ) =
// ρ·(1.7 − 0.7ρ)·UNITY_SPECCUBE_LOD_STEPS with UNITY_SPECCUBE_LOD_STEPS = 6:
//   built-in: CGIncludes/UnityStandardConfig.cginc:10-11 (#define UNITY_SPECCUBE_LOD_STEPS (6)),
//             CGIncludes/UnityImageBasedLighting.cginc:510-512 and 538-544 (Unity_GlossyEnvironment:
//             perceptualRoughness*(1.7 - 0.7*perceptualRoughness), then UNITY_SAMPLE_TEXCUBE_LOD(tex, R, mip))
//             (Unity 2022.3.43f1's built-in shaders, as mirrored in github.com/Lex-DRL/unity-builtin_shaders);
//   SRP core (URP): Packages/com.unity.render-pipelines.core/ShaderLibrary/ImageBasedLighting.hlsl:14-17
//             (UNITY_SPECCUBE_LOD_STEPS 6) and 27-37 (PerceptualRoughnessToMipmapLevel), used by URP's
//             GlossyEnvironmentReflection (ShaderLibrary/GlobalIllumination.hlsl) on unity_SpecCube0
//             (github.com/Unity-Technologies/Graphics, commit 0c658a0).
// So Unity level m must hold the radiance prefiltered for the roughness ρ_m that solves
// ρ(1.7 − 0.7ρ)·6 = m (ρ_0 = 0, ρ_6 = 1; Graphics' MipmapLevelToPerceptualRoughness is the same
// inverse). The provider's chain holds roughness k/(K − 1) at mip k; Unity level m gets, at each
// texel, exactly what the provider's own shaders return for ρ_m there (shaders/ibl.*:
// textureLod(cube, d, ρ_m·(K − 1)): bilinear within a face with seamless edges, linear between
// mips; the CPU twin of provider/verify/cubemap.py's CubeSampler).
//
// Faces. Unity samples a cube with its left-handed world direction d_U through the same face
// table (Direct3D's, equal to OpenGL's), and a Cubemap face's pixel data starts with the top row
// (Cubemap.SetPixels: "top to bottom, row after row"), which is t = 0 of the table. The wire
// direction of d_U is d = S·d_U, S = diag(1, 1, −1), and working the table through S gives:
//   Unity +X = wire +X, columns mirrored      Unity −X = wire −X, columns mirrored
//   Unity +Y = wire +Y, rows mirrored         Unity −Y = wire −Y, rows mirrored
//   Unity +Z = wire −Z, columns mirrored      Unity −Z = wire +Z, columns mirrored
// (e.g. Unity +X: sc_U = −z_U, and wire +X has sc = −z = +z_U = −sc_U). The baker does not rely on
// this table: it computes each Unity texel's direction and samples the wire cube there (the
// table is what tests/clients/unity/test_unity_cube.py checks with one-sided scenes).
using System;

namespace Shlight.Lighting
{
    /// <summary>Bakes <see cref="Sh9EnvironmentCube"/>s into Unity cube texels (RGBA halves, Unity
    /// frame, Unity's mip curve, a probe rotation). Buffers are kept between bakes: a bake of a cube of
    /// the same size allocates nothing. Not thread-safe: one thread bakes at a time.</summary>
    public sealed class Sh9UnityCubeBaker
    {
        /// <summary>UNITY_SPECCUBE_LOD_STEPS: the last mip Unity's shaders read (roughness 1).</summary>
        public const int UnityLodSteps = 6;
        /// <summary>Levels of the Unity cube: 0 … <see cref="UnityLodSteps"/>.</summary>
        public const int Levels = UnityLodSteps + 1;
        /// <summary>Smallest Unity face size: 2^7 keeps level 6 (roughness 1) at 2×2 and level 5 (0.68) at 4×4,
        /// like Unity's own default 128 reflection probes and the provider's roughest mips (a 64² cube's 1×1
        /// and 2×2 levels are too small for those lobes: a rough sphere was 18 % off, median, against 4 %).</summary>
        public const int MinUnitySize = 2 << UnityLodSteps;

        /// <summary>Face size of the Unity cube (max(provider size, 128)).</summary>
        public int Size { get; private set; }
        /// <summary>Level m, face F (Unity's CubemapFace order = the wire's order of names), rows top (t = 0)
        /// first, texels R G B A as IEEE halves (A = 1): the layout of Cubemap.SetPixelData for RGBAHalf.</summary>
        public ushort[] Data { get; private set; }
        /// <summary>Bakes done (a counter for callers).</summary>
        public long Bakes { get; private set; }

        float[][] padded = new float[0][];   // per provider mip: (6, n+2, n+2, 3) with seamless borders
        int paddedSize = -1;
        readonly double[] r = new double[9];
        readonly float[] rgb = new float[3];
        readonly float[] tap = new float[3];

        /// <summary>Perceptual roughness that Unity's shaders read at level <paramref name="m"/>:
        /// the root of ρ(1.7 − 0.7ρ)·6 = m in [0, 1].</summary>
        public static double UnityLevelRoughness(double m)
        {
            double x = Math.Max(0, Math.Min(1, m / UnityLodSteps));
            return Math.Max(0, Math.Min(1, (1.7 - Math.Sqrt(Math.Max(0, 2.89 - 2.8 * x))) / 1.4));
        }

        /// <summary>perceptualRoughnessToMipmapLevel: ρ(1.7 − 0.7ρ)·6.</summary>
        public static double UnityMipForRoughness(double roughness)
        {
            return roughness * (1.7 - 0.7 * roughness) * UnityLodSteps;
        }

        /// <summary>Offset in <see cref="Data"/> of level <paramref name="level"/>, face <paramref name="face"/>.</summary>
        public int Offset(int level, int face) { return Offset(Size, level, face); }
        /// <summary>Halves per face at <paramref name="level"/> (4 per texel).</summary>
        public int FaceLength(int level) { return FaceLength(Size, level); }

        /// <summary>Halves per face of level <paramref name="level"/> of a Unity cube of face size <paramref name="size"/>.</summary>
        public static int FaceLength(int size, int level) { int n = Math.Max(1, size >> level); return 4 * n * n; }

        /// <summary>Offset of level <paramref name="level"/>, face <paramref name="face"/> in the data of a Unity cube of face size <paramref name="size"/>.</summary>
        public static int Offset(int size, int level, int face)
        {
            int o = 0;
            for (int m = 0; m < level; m++) o += 6 * FaceLength(size, m);
            return o + face * FaceLength(size, level);
        }

        /// <summary>Face size of the Unity cube made from a provider cube of face size <paramref name="providerSize"/>.</summary>
        public static int UnitySize(int providerSize) { return Math.Max(providerSize, MinUnitySize); }

        void Allocate(int providerSize, int mips)
        {
            int size = UnitySize(providerSize);
            if (size != Size || Data == null)
            {
                Size = size;
                Data = new ushort[Offset(size, Levels, 0)];
            }
            if (providerSize != paddedSize || padded.Length != mips)
            {
                padded = new float[mips][];
                for (int k = 0; k < mips; k++)
                {
                    int n = providerSize >> k;
                    padded[k] = new float[6 * (n + 2) * (n + 2) * 3];
                }
                paddedSize = providerSize;
            }
        }

        /// <summary>
        /// Bake <paramref name="cube"/> for a probe whose orientation in Unity's world is the 3×3 row-major
        /// <paramref name="unityRotation"/> (what SH9LightingClient applies to the coefficients: a direction
        /// d seen by the camera, in Unity's frame, is world direction R·d; null = identity).
        /// </summary>
        public void Bake(Sh9EnvironmentCube cube, double[] unityRotation)
        {
            if (cube == null) throw new ArgumentNullException("cube");
            Allocate(cube.Size, cube.MipCount);
            for (int k = 0; k < cube.MipCount; k++) Pad(cube.Mips[k], cube.Size >> k, padded[k]);
            if (unityRotation == null) { Array.Clear(r, 0, 9); r[0] = r[4] = r[8] = 1; }
            else Array.Copy(unityRotation, r, 9);
            int lastMip = cube.MipCount - 1;
            ushort one = Sh9Ktx2.FloatToHalf(1f);
            for (int m = 0; m < Levels; m++)
            {
                int n = Math.Max(1, Size >> m);
                double lod = UnityLevelRoughness(m) * lastMip;
                for (int face = 0; face < 6; face++)
                {
                    int o = Offset(m, face);
                    for (int i = 0; i < n; i++)
                    {
                        double b = (i + 0.5) / n * 2 - 1;
                        for (int j = 0; j < n; j++)
                        {
                            double a = (j + 0.5) / n * 2 - 1, ux, uy, uz;
                            FacePoint(face, a, b, out ux, out uy, out uz);     // Unity world direction
                            // probe frame: Rᵀ·d_U; wire frame: z negated
                            double px = r[0] * ux + r[3] * uy + r[6] * uz;
                            double py = r[1] * ux + r[4] * uy + r[7] * uz;
                            double pz = r[2] * ux + r[5] * uy + r[8] * uz;
                            Sample(cube, px, py, -pz, lod);
                            Data[o++] = Sh9Ktx2.FloatToHalf(rgb[0]);
                            Data[o++] = Sh9Ktx2.FloatToHalf(rgb[1]);
                            Data[o++] = Sh9Ktx2.FloatToHalf(rgb[2]);
                            Data[o++] = one;
                        }
                    }
                }
            }
            Bakes++;
        }

        // The OpenGL/Direct3D table: the point on face f's plane at a = 2s − 1, b = 2t − 1.
        static void FacePoint(int face, double a, double b, out double x, out double y, out double z)
        {
            switch (face)
            {
                case 0: x = 1; y = -b; z = -a; break;     // +X: sc = −z, tc = −y
                case 1: x = -1; y = -b; z = a; break;     // −X: sc = +z, tc = −y
                case 2: x = a; y = 1; z = b; break;       // +Y: sc = +x, tc = +z
                case 3: x = a; y = -1; z = -b; break;     // −Y: sc = +x, tc = −z
                case 4: x = a; y = -b; z = 1; break;      // +Z: sc = +x, tc = −y
                default: x = -a; y = -b; z = -1; break;   // −Z: sc = −x, tc = −y
            }
        }

        // Face and (s, t) of a direction: the major axis (ties x before y before z).
        static int ToFace(double x, double y, double z, out double s, out double t)
        {
            double ax = Math.Abs(x), ay = Math.Abs(y), az = Math.Abs(z), sc, tc, ma;
            int face;
            if (ax >= ay && ax >= az) { face = x >= 0 ? 0 : 1; ma = ax; sc = x >= 0 ? -z : z; tc = -y; }
            else if (ay >= az) { face = y >= 0 ? 2 : 3; ma = ay; sc = x; tc = y >= 0 ? z : -z; }
            else { face = z >= 0 ? 4 : 5; ma = az; sc = z >= 0 ? x : -x; tc = -y; }
            s = (sc / ma + 1) / 2;
            t = (tc / ma + 1) / 2;
            return face;
        }

        // The texel of an n×n mip containing direction (x, y, z).
        static int Nearest(double x, double y, double z, int n)
        {
            double s, t;
            int f = ToFace(x, y, z, out s, out t);
            int i = Math.Min(n - 1, Math.Max(0, (int)Math.Floor(t * n)));
            int j = Math.Min(n - 1, Math.Max(0, (int)Math.Floor(s * n)));
            return (f * n + i) * n + j;
        }

        // Each face with a one-texel border from its neighbours (provider/verify/cubemap.py padded_faces):
        // a border texel off one edge is the texel across that edge; off a corner, the mean of the
        // three texels meeting at that cube corner.
        static void Pad(float[] mip, int n, float[] outp)
        {
            int w = n + 2;
            for (int f = 0; f < 6; f++)
            {
                for (int pi = 0; pi < w; pi++)
                {
                    double b = (pi - 1 + 0.5) / n * 2 - 1;
                    for (int pj = 0; pj < w; pj++)
                    {
                        double a = (pj - 1 + 0.5) / n * 2 - 1;
                        int dst = ((f * w + pi) * w + pj) * 3;
                        bool outA = Math.Abs(a) > 1, outB = Math.Abs(b) > 1;
                        if (!outA && !outB)
                        {
                            int src = ((f * n + pi - 1) * n + pj - 1) * 3;
                            outp[dst] = mip[src]; outp[dst + 1] = mip[src + 1]; outp[dst + 2] = mip[src + 2];
                            continue;
                        }
                        double x, y, z;
                        FacePoint(f, a, b, out x, out y, out z);
                        if (outA != outB)
                        {
                            x = Fold(x, n); y = Fold(y, n); z = Fold(z, n);
                            int src = Nearest(x, y, z, n) * 3;
                            outp[dst] = mip[src]; outp[dst + 1] = mip[src + 1]; outp[dst + 2] = mip[src + 2];
                            continue;
                        }
                        double qx = Math.Sign(x), qy = Math.Sign(y), qz = Math.Sign(z), inner = 1 - 1.0 / n;
                        int t0 = Nearest(qx, qy * inner, qz * inner, n) * 3;
                        int t1 = Nearest(qx * inner, qy, qz * inner, n) * 3;
                        int t2 = Nearest(qx * inner, qy * inner, qz, n) * 3;
                        for (int c = 0; c < 3; c++)
                            outp[dst + c] = (float)(((double)mip[t0 + c] + mip[t1 + c] + mip[t2 + c]) / 3.0);
                    }
                }
            }
        }

        // A border point's coordinate: past the cube (|v| > 1) onto the edge; the face's own axis
        // (|v| = 1) half a texel in, so that it lands on the neighbour's texel centre.
        static double Fold(double v, int n)
        {
            double av = Math.Abs(v);
            if (av > 1 + 1e-9) return Math.Sign(v);
            if (av > 1 - 1e-9) return Math.Sign(v) * (1 - 1.0 / n);
            return v;
        }

        // rgb = textureLod(cube, d, lod) (d in the wire frame): trilinear, seamless.
        void Sample(Sh9EnvironmentCube cube, double x, double y, double z, double lod)
        {
            double s, t;
            int face = ToFace(x, y, z, out s, out t);
            int last = cube.MipCount - 1;
            lod = Math.Max(0, Math.Min(last, lod));
            int lo = (int)Math.Floor(lod);
            double frac = lod - lo;
            int hi = Math.Min(lo + 1, last);
            Bilinear(padded[lo], cube.Size >> lo, face, s, t);
            double r0 = tap[0], g0 = tap[1], b0 = tap[2];
            if (frac > 0)
            {
                Bilinear(padded[hi], cube.Size >> hi, face, s, t);
                r0 += frac * (tap[0] - r0); g0 += frac * (tap[1] - g0); b0 += frac * (tap[2] - b0);
            }
            rgb[0] = (float)r0; rgb[1] = (float)g0; rgb[2] = (float)b0;
        }

        void Bilinear(float[] p, int n, int face, double s, double t)
        {
            int w = n + 2;
            double u = s * n - 0.5, v = t * n - 0.5;
            int j0 = (int)Math.Floor(u), i0 = (int)Math.Floor(v);
            double fu = u - j0, fv = v - i0;
            j0 = Math.Min(n - 1, Math.Max(-1, j0)) + 1;
            i0 = Math.Min(n - 1, Math.Max(-1, i0)) + 1;
            int a = ((face * w + i0) * w + j0) * 3, b = a + 3, c = a + 3 * w, d = c + 3;
            for (int k = 0; k < 3; k++)
                tap[k] = (float)((1 - fv) * ((1 - fu) * p[a + k] + fu * p[b + k]) + fv * ((1 - fu) * p[c + k] + fu * p[d + k]));
        }
    }
}
