// The provider's reflection cube (docs/contract.md §12) as read from its KTX 2.0 file, the
// container it travels in everywhere (/environment.ktx2, the binary frame after an
// "environment" WebSocket message, MQTT). Plain C#, no UnityEngine.
//
// The file (provider/live/reflections/ktx2.py): vkFormat 97 (R16G16B16A16_SFLOAT), faceCount 6, levels
// n, n/2, ... 2 (smallest first in the file, found through the level index), faces in the
// OpenGL order +X −X +Y −Y +Z −Z, each face its rows from row 0 (t smallest), texels R G B A
// as little-endian IEEE halves; texel [f, i, j] looks along the OpenGL cube-map table applied
// to a direction in the wire frame (right-handed, +Y up). Key/value data: shlight.roughness
// (one per mip), shlight.seq, shlight.sh9_seq, shlight.frame, shlight.units, shlight.probe.
using System;
using System.Collections.Generic;
using System.Runtime.InteropServices;
using System.Text;

namespace Shlight.Lighting
{
    /// <summary>One reflection cube as the provider made it (immutable once parsed): RGB radiance
    /// per texel in the units of the sh9 coefficients, wire frame, the provider's mip chain.</summary>
    public sealed class Sh9EnvironmentCube
    {
        /// <summary>Face size of mip 0 (a power of two, 8 … 256).</summary>
        public readonly int Size;
        /// <summary>Mips[k]: 6·n_k·n_k·3 floats (n_k = Size >> k), faces +X −X +Y −Y +Z −Z, rows from t = 0,
        /// texels R G B: exactly the halves of the file.</summary>
        public readonly float[][] Mips;
        /// <summary>Perceptual roughness of each mip (k / (mips − 1) unless the file says otherwise).</summary>
        public readonly double[] Roughness;
        /// <summary>shlight.seq (the probe's cube counter), shlight.sh9_seq; -1 when absent.</summary>
        public readonly long Seq, Sh9Seq;
        public readonly string Probe, Units;

        public Sh9EnvironmentCube(int size, float[][] mips, double[] roughness, long seq, long sh9Seq,
                                  string probe, string units)
        {
            Size = size; Mips = mips; Roughness = roughness; Seq = seq; Sh9Seq = sh9Seq;
            Probe = probe; Units = units;
        }

        public int MipCount { get { return Mips.Length; } }

        /// <summary>Texel [face, row, column] of mip k, channel c (wire layout).</summary>
        public float Texel(int k, int face, int row, int column, int c)
        {
            int n = Size >> k;
            return Mips[k][((face * n + row) * n + column) * 3 + c];
        }
    }

    /// <summary>Reads the provider's KTX 2.0 cube files; anything else is a <see cref="FormatException"/>
    /// with one readable reason.</summary>
    public static class Sh9Ktx2
    {
        static readonly byte[] Identifier = { 0xAB, 0x4B, 0x54, 0x58, 0x20, 0x32, 0x30, 0xBB, 0x0D, 0x0A, 0x1A, 0x0A };
        public const int VkFormatR16G16B16A16Sfloat = 97;
        public const int MinSize = 8, MaxSize = 256;

        /// <summary>Parse <paramref name="length"/> bytes of <paramref name="data"/> from <paramref name="offset"/>.</summary>
        public static Sh9EnvironmentCube Parse(byte[] data, int offset, int length)
        {
            if (data == null) throw new ArgumentNullException("data");
            if (offset < 0 || length < 0 || offset + length > data.Length) throw new ArgumentOutOfRangeException("length");
            if (length < 80) throw new FormatException("not a KTX 2.0 file: " + length + " bytes");
            for (int i = 0; i < Identifier.Length; i++)
                if (data[offset + i] != Identifier[i]) throw new FormatException("not a KTX 2.0 file (wrong identifier)");
            int p = offset + 12;
            uint vkFormat = U32(data, p), typeSize = U32(data, p + 4), width = U32(data, p + 8), height = U32(data, p + 12),
                 depth = U32(data, p + 16), layers = U32(data, p + 20), faces = U32(data, p + 24), levels = U32(data, p + 28),
                 supercompression = U32(data, p + 32);
            if (vkFormat != VkFormatR16G16B16A16Sfloat || typeSize != 2)
                throw new FormatException("KTX2 format " + vkFormat + " is not R16G16B16A16_SFLOAT (97): not a shlight cube");
            if (faces != 6 || layers != 0 || depth != 0) throw new FormatException("KTX2 is not a cube map (faceCount " + faces + ")");
            if (width != height || width < MinSize || width > MaxSize || (width & (width - 1)) != 0)
                throw new FormatException("cube size " + width + "x" + height + " is not a power of two from " + MinSize + " to " + MaxSize);
            if (supercompression != 0) throw new FormatException("supercompressed KTX2 (scheme " + supercompression + ") is not supported");
            int size = (int)width, maxLevels = 0;
            for (int n = size; n >= 1; n >>= 1) maxLevels++;
            if (levels < 1 || levels > maxLevels) throw new FormatException("KTX2 level count " + levels + " out of range");
            int kvdOffset = (int)U32(data, p + 44), kvdLength = (int)U32(data, p + 48);
            int index = p + 68;                    // after the header (36) and the index (32)
            if (index - offset + 24 * (int)levels > length) throw new FormatException("KTX2 truncated in its level index");
            var mips = new float[levels][];
            for (int k = 0; k < levels; k++)
            {
                ulong at = U64(data, index + 24 * k), bytes = U64(data, index + 24 * k + 8);
                int n = size >> k;
                ulong want = (ulong)(6 * n * n * 8);
                if (bytes != want) throw new FormatException("KTX2 level " + k + " has " + bytes + " bytes, expected " + want);
                if (at + bytes > (ulong)length) throw new FormatException("KTX2 truncated in level " + k);
                var mip = new float[6 * n * n * 3];
                int src = offset + (int)at;
                for (int t = 0, dst = 0; t < 6 * n * n; t++, src += 8)
                {
                    mip[dst++] = HalfToFloat(U16(data, src));
                    mip[dst++] = HalfToFloat(U16(data, src + 2));
                    mip[dst++] = HalfToFloat(U16(data, src + 4));
                }
                mips[k] = mip;
            }
            var kv = KeyValues(data, offset, length, kvdOffset, kvdLength);
            string frame;
            if (kv.TryGetValue("shlight.frame", out frame) && frame != Sh9Message.WireFrame)
                throw new FormatException("cube frame \"" + frame + "\" is not \"" + Sh9Message.WireFrame + "\"");
            var roughness = new double[levels];
            for (int k = 0; k < levels; k++) roughness[k] = levels == 1 ? 0 : k / (double)(levels - 1);
            string text;
            if (kv.TryGetValue("shlight.roughness", out text))
            {
                List<object> list = MiniJson.Parse(text) as List<object>;
                if (list == null || list.Count != levels) throw new FormatException("shlight.roughness must list one number per mip");
                for (int k = 0; k < levels; k++)
                {
                    if (!(list[k] is double)) throw new FormatException("shlight.roughness[" + k + "] is not a number");
                    roughness[k] = (double)list[k];
                }
            }
            string units, probe;
            kv.TryGetValue("shlight.units", out units);
            kv.TryGetValue("shlight.probe", out probe);
            return new Sh9EnvironmentCube(size, mips, roughness, Integer(kv, "shlight.seq"), Integer(kv, "shlight.sh9_seq"),
                                          probe, units);
        }

        static long Integer(Dictionary<string, string> kv, string key)
        {
            string text;
            long v;
            if (kv.TryGetValue(key, out text) && long.TryParse(text, System.Globalization.NumberStyles.Integer,
                                                                 System.Globalization.CultureInfo.InvariantCulture, out v))
                return v;
            return -1;
        }

        static Dictionary<string, string> KeyValues(byte[] data, int offset, int length, int at, int count)
        {
            var kv = new Dictionary<string, string>(StringComparer.Ordinal);
            if (count == 0) return kv;
            if (at < 0 || count < 0 || at + count > length) throw new FormatException("KTX2 key/value data out of range");
            int p = offset + at, end = p + count;
            while (p + 4 <= end)
            {
                int n = (int)U32(data, p);
                p += 4;
                if (n < 0 || p + n > end) throw new FormatException("KTX2 key/value entry out of range");
                int nul = Array.IndexOf(data, (byte)0, p, n);
                if (nul < 0) throw new FormatException("KTX2 key without its NUL");
                string key = Encoding.UTF8.GetString(data, p, nul - p);
                int valueEnd = p + n;
                if (valueEnd > nul + 1 && data[valueEnd - 1] == 0) valueEnd--;
                kv[key] = Encoding.UTF8.GetString(data, nul + 1, Math.Max(0, valueEnd - nul - 1));
                p += n + ((4 - n % 4) % 4);
            }
            return kv;
        }

        static ushort U16(byte[] b, int p) { return (ushort)(b[p] | b[p + 1] << 8); }
        static uint U32(byte[] b, int p) { return (uint)(b[p] | b[p + 1] << 8 | b[p + 2] << 16 | b[p + 3] << 24); }
        static ulong U64(byte[] b, int p) { return U32(b, p) | (ulong)U32(b, p + 4) << 32; }

        [StructLayout(LayoutKind.Explicit)]
        struct FloatBits
        {
            [FieldOffset(0)] public float F;
            [FieldOffset(0)] public uint U;
        }

        /// <summary>IEEE half (binary16) to float, exactly.</summary>
        public static float HalfToFloat(ushort h)
        {
            uint sign = (uint)(h & 0x8000) << 16, exp = (uint)(h >> 10) & 0x1f, mant = (uint)h & 0x3ff;
            var b = new FloatBits();
            if (exp == 0)
            {
                if (mant == 0) { b.U = sign; return b.F; }
                float v = mant * (1f / 16777216f);   // subnormal: mant · 2^-24
                return sign != 0 ? -v : v;
            }
            if (exp == 31) b.U = sign | 0x7f800000 | (mant << 13);
            else b.U = sign | ((exp + 112) << 23) | (mant << 13);
            return b.F;
        }

        /// <summary>Float to IEEE half, rounded to nearest even; beyond ±65504 clamped to ±65504
        /// (as the provider writes), NaN stays NaN. Allocates nothing.</summary>
        public static ushort FloatToHalf(float value)
        {
            var b = new FloatBits { F = value };
            uint f = b.U, sign = (f >> 16) & 0x8000;
            f &= 0x7fffffff;
            if (f > 0x7f800000) return (ushort)(sign | 0x7e00);
            if (f >= 0x477fe000) return (ushort)(sign | 0x7bff);          // >= 65504: the largest half
            if (f >= 0x38800000)                                           // a normal half (>= 2^-14)
            {
                uint h = ((f >> 23) - 112) << 10 | (f & 0x7fffff) >> 13, rest = f & 0x1fff;
                if (rest > 0x1000 || (rest == 0x1000 && (h & 1) != 0)) h++;
                return (ushort)(sign | h);
            }
            if (f < 0x33000000) return (ushort)sign;                      // below half the smallest subnormal
            uint e = f >> 23, m = (f & 0x7fffff) | 0x800000;
            int shift = (int)(126 - e);
            uint hm = m >> shift, rem = m & ((1u << shift) - 1), halfway = 1u << (shift - 1);
            if (rem > halfway || (rem == halfway && (hm & 1) != 0)) hm++;
            return (ushort)(sign | hm);
        }
    }
}
