// Shadows from the room's lights (issue 30; docs/contract.md §10, docs/shadows_consumers.md): which light
// casts them (the key light), how soft they are (its angular radius), and the ratio a shadow catcher
// multiplies the camera image by. Plain C#, no UnityEngine: the MonoBehaviour and the Mono tests share it.
using System;

namespace Shlight.Lighting
{
    /// <summary>Unity's two real-time shadow types of a Light (LightShadows.Hard / Soft).</summary>
    public enum Sh9ShadowType { Hard = 1, Soft = 2 }

    public static class Sh9Shadows
    {
        /// <summary>A key light stays key until another is brighter by more than this factor − 1, so that
        /// two near-equal lamps do not make the shadow jump between them.</summary>
        public const double KeyHysteresis = 0.1;

        /// <summary>Angular radius (degrees) from which the key light's shadow is Soft: the sun (0.27°) casts
        /// a penumbra of 2·h·tan r ≈ 1 cm per metre of height, under a shadow-map texel at room scale, so
        /// Hard; a lamp shade or softbox (several degrees) a visibly blurred one, so Soft.</summary>
        public const double SoftAboveDeg = 0.5;

        static double Luminance(double[] rgb, int offset)
        {
            return Sh9LightTemperature.Luminance(rgb[offset], rgb[offset + 1], rgb[offset + 2]);
        }

        /// <summary>Index of the key light: the brightest of <paramref name="lights"/> lights (Rec. 709
        /// luminance of its irradiance, as the provider's webxr export picks its primary light), kept at
        /// <paramref name="previous"/> while that one is within <see cref="KeyHysteresis"/> of the brightest.
        /// −1 when there are no lights.</summary>
        public static int KeyLightIndex(double[] lightIrradiance, int lights, int previous)
        {
            if (lightIrradiance == null || lights <= 0 || lightIrradiance.Length < 3 * lights) return -1;
            int best = 0;
            double bestY = Luminance(lightIrradiance, 0);
            for (int i = 1; i < lights; i++)
            {
                double y = Luminance(lightIrradiance, 3 * i);
                if (y > bestY) { best = i; bestY = y; }
            }
            if (previous >= 0 && previous < lights &&
                Luminance(lightIrradiance, 3 * previous) * (1 + KeyHysteresis) >= bestY)
                return previous;
            return best;
        }

        /// <summary>Hard below <see cref="SoftAboveDeg"/>, Soft from there on. Unity's built-in pipeline and
        /// URP filter soft shadows over a fixed footprint (PCF; URP 14+ lets a light pick Low/Medium/High),
        /// not over the light's size: this is the one choice the engine leaves to a script at run time.</summary>
        public static Sh9ShadowType ShadowType(double angularRadiusDeg)
        {
            return angularRadiusDeg >= SoftAboveDeg ? Sh9ShadowType.Soft : Sh9ShadowType.Hard;
        }

        /// <summary>Width (same unit as <paramref name="casterHeight"/>) of the penumbra a disc light of
        /// angular radius r casts past an edge <paramref name="casterHeight"/> above the receiver: 2·h·tan r.</summary>
        public static double PenumbraWidth(double angularRadiusDeg, double casterHeight)
        {
            if (!(angularRadiusDeg > 0) || !(casterHeight > 0)) return 0;
            return 2 * casterHeight * Math.Tan(Math.Min(angularRadiusDeg, 89.0) * Math.PI / 180);
        }

        /// <summary>
        /// The ratio a shadow catcher multiplies the camera image by (provider/core/lights/shadows.py
        /// shadow_ratio; SHShadowRatio in sh9_lights.hlsl), per colour, into <paramref name="rgb"/>:
        /// (E_a(n) + Σ V_k I_k max(0, n·d_k)) / (E_a(n) + Σ I_k max(0, n·d_k)), E_a(n) = max(0, ñᵀAñ);
        /// 1 where nothing lights the receiver. <paramref name="ambientMatrices"/>: 48 numbers (M_r, M_g, M_b);
        /// directions (unit, toward each light) and normal in the same frame; <paramref name="visibility"/>:
        /// k fractions in [0, 1] (null: every light visible).
        /// </summary>
        public static void ShadowRatio(double[] ambientMatrices, double[] lightDirections, double[] lightIrradiance,
                                       int lights, double nx, double ny, double nz, double[] visibility, double[] rgb)
        {
            ShadowRatio(ambientMatrices, lightDirections, lightIrradiance, lights, nx, ny, nz, visibility, null, rgb);
        }

        /// <summary>The bounding sphere of an axis-aligned box (min, max corners): centre the box's centre,
        /// radius half its diagonal; into <paramref name="sphere"/> (x, y, z, radius). What SH9ShadowOccluder
        /// uploads as _SHOccluderSphere from a hologram's renderer bounds.</summary>
        public static void BoundingSphere(double minX, double minY, double minZ, double maxX, double maxY, double maxZ,
                                          double[] sphere)
        {
            double hx = 0.5 * (maxX - minX), hy = 0.5 * (maxY - minY), hz = 0.5 * (maxZ - minZ);
            sphere[0] = minX + hx;
            sphere[1] = minY + hy;
            sphere[2] = minZ + hz;
            sphere[3] = Math.Sqrt(hx * hx + hy * hy + hz * hz);
        }

        /// <summary>The SH9 ambient's radiance toward unit (dx, dy, dz) from its irradiance matrix alone (channel
        /// c of 48 numbers): (4 dᵀBd + 3 m·d + M33 − tr B) / π; not clamped (sh9_lights.hlsl SHRadianceFromMatrix,
        /// provider.core.lights.shadows.ambient_radiance).</summary>
        public static double AmbientRadiance(double[] matrices, int c, double dx, double dy, double dz)
        {
            int o = 16 * c;
            double[] d = { dx, dy, dz };
            double quad = 0, lin = 0, trace = 0;
            for (int i = 0; i < 3; i++)
            {
                for (int j = 0; j < 3; j++) quad += d[i] * matrices[o + 4 * i + j] * d[j];
                lin += matrices[o + 4 * i + 3] * d[i];
                trace += matrices[o + 5 * i];
            }
            return (4 * quad + 3 * lin + matrices[o + 15] - trace) / Math.PI;
        }

        /// <summary>∫ over a cap of half-angle α of max(0, n·ω) dω, cos θ = n·d to its axis: π sin²α cos θ above
        /// the horizon, 0 below, the exact horizon-cut value between (Snyder 1996); sin α ≥ 1 is a hemisphere.</summary>
        public static double CapProjectedSolidAngle(double cosToCap, double sinHalfAngle)
        {
            double h = Math.Min(1.0, Math.Max(-1.0, cosToCap)), s = Math.Min(1.0, Math.Max(0.0, sinHalfAngle)), s2 = s * s;
            if (h * h >= s2) return Math.PI * s2 * Math.Max(h, 0.0);
            double sinT = Math.Sqrt(Math.Max(1 - h * h, 0.0));
            double x = Math.Sqrt(Math.Max(1 - s2, 0.0)) / Math.Max(s, 1e-30);
            double y = Math.Min(1.0, Math.Max(-1.0, -x * h / Math.Max(sinT, 1e-30)));
            double sy = Math.Sqrt(Math.Max((s - h) * (s + h), 0.0)) / Math.Max(s, 1e-30);
            return Math.Max((h * Math.Acos(y) - x * sy) * s2 + Math.Atan2(sy, x), 0.0);
        }

        /// <summary>
        /// The ambient irradiance an occluding sphere (x, y, z, radius; radius ≤ 0: none, zeros) hides from a
        /// receiver of unit normal n at point p, per colour into <paramref name="rgb"/> (SHOccludedAmbientOfSphere in
        /// sh9_lights.hlsl; provider.core.lights.shadows.occluded_ambient): max(0, L_a(d)) · P(n·d, R/|c − p|),
        /// d = (c − p)/|c − p|. Matrices, normal, point and sphere in one frame.
        /// </summary>
        public static void OccludedAmbient(double[] ambientMatrices, double nx, double ny, double nz,
                                           double px, double py, double pz, double[] sphere, double[] rgb)
        {
            if (!(sphere[3] > 0)) { rgb[0] = rgb[1] = rgb[2] = 0; return; }
            double tx = sphere[0] - px, ty = sphere[1] - py, tz = sphere[2] - pz;
            double dist = Math.Sqrt(tx * tx + ty * ty + tz * tz);
            if (dist > 0) { tx /= dist; ty /= dist; tz /= dist; } else { tx = nx; ty = ny; tz = nz; }
            double cap = CapProjectedSolidAngle(nx * tx + ny * ty + nz * tz, sphere[3] / Math.Max(dist, 1e-30));
            for (int c = 0; c < 3; c++)
                rgb[c] = Math.Max(AmbientRadiance(ambientMatrices, c, tx, ty, tz), 0.0) * cap;
        }

        /// <summary>ShadowRatio with the occluder's ambient occlusion <paramref name="occluded"/> (3 numbers ≥ 0,
        /// from <see cref="OccludedAmbient"/>; null: none) taken off the ambient in the numerator, never below
        /// zero (SHShadowRatioOccluded).</summary>
        public static void ShadowRatio(double[] ambientMatrices, double[] lightDirections, double[] lightIrradiance,
                                       int lights, double nx, double ny, double nz, double[] visibility,
                                       double[] occluded, double[] rgb)
        {
            for (int c = 0; c < 3; c++)
            {
                double a = Math.Max(Sh9Math.Irradiance(ambientMatrices, c, nx, ny, nz), 0.0);
                double lit = occluded == null ? a : Math.Max(a - Math.Max(occluded[c], 0.0), 0.0), open = a;
                for (int k = 0; k < lights; k++)
                {
                    double cos = Math.Max(0.0, nx * lightDirections[3 * k] + ny * lightDirections[3 * k + 1] +
                                               nz * lightDirections[3 * k + 2]);
                    double e = lightIrradiance[3 * k + c] * cos;
                    double v = visibility == null ? 1.0 : Math.Min(1.0, Math.Max(0.0, visibility[k]));
                    lit += v * e;
                    open += e;
                }
                rgb[c] = open > 0 ? lit / open : 1.0;
            }
        }
        /// <summary>
        /// The unoccluded fraction of a light's uniform disc (unit direction (dx, dy, dz) toward it, angular radius
        /// <paramref name="angularRadiusDeg"/> degrees) seen from point p behind a sphere (x, y, z, radius; radius ≤ 0:
        /// none, 1): 1 − Ω(disc ∩ sphere's cap)/Ω(disc), the exact solid angle of two intersecting caps
        /// (provider.core.lights.shadows.sphere_light_visibility; SHSphereLightVisibility in sh9_lights.hlsl). A point
        /// inside the sphere sees nothing: 0. Point, sphere and direction in one frame.
        /// </summary>
        public static double SphereLightVisibility(double px, double py, double pz, double[] sphere,
                                                   double dx, double dy, double dz, double angularRadiusDeg)
        {
            if (!(sphere[3] > 0)) return 1.0;
            double tx = sphere[0] - px, ty = sphere[1] - py, tz = sphere[2] - pz;
            double dist = Math.Sqrt(tx * tx + ty * ty + tz * tz);
            if (dist <= sphere[3]) return 0.0;
            tx /= dist; ty /= dist; tz /= dist;
            double cx = ty * dz - tz * dy, cy = tz * dx - tx * dz, cz = tx * dy - ty * dx;
            double g = Math.Atan2(Math.Sqrt(cx * cx + cy * cy + cz * cz), tx * dx + ty * dy + tz * dz);
            double alpha = Math.Asin(sphere[3] / dist), a = Math.Max(angularRadiusDeg, 0.0) * Math.PI / 180;
            return 1.0 - CapOverlapFraction(a, alpha, g);
        }

        /// <summary>Ω(cap_a ∩ cap_α) / Ω(cap_a) for caps of angular radii a (the light) and α whose axes are g apart
        /// (radians), in [0, 1]: the great circle through the rims' crossings cuts the lens into one segment of each
        /// cap (sector less isosceles spherical triangle); a = 0 (a point): 1 inside, 0 outside.</summary>
        public static double CapOverlapFraction(double a, double alpha, double g)
        {
            if (a <= 0) return g < alpha ? 1.0 : 0.0;
            if (g >= a + alpha) return 0.0;
            if (g <= alpha - a) return 1.0;
            double sa = Math.Sin(0.5 * a), sal = Math.Sin(0.5 * alpha), areaRatio = sal * sal / (sa * sa);
            if (g <= a - alpha) return Math.Min(areaRatio, 1.0);
            double lens = CapSegment(a, 2 * CapHalfChord(a, alpha, g)) + areaRatio * CapSegment(alpha, 2 * CapHalfChord(alpha, a, g));
            return Math.Min(1.0, Math.Max(0.0, lens / (4 * Math.PI)));
        }

        // The segment of a cap of half-angle x cut off by a great circle whose chord subtends c at its axis, in units
        // of sin²(x/2): the sector 2c less the isosceles spherical triangle.
        static double CapSegment(double x, double c)
        {
            double s2 = Math.Sin(0.5 * x);
            s2 *= s2;
            double tri = s2 > 0 ? Math.Atan2(s2 * Math.Sin(c), (1 - s2) + s2 * Math.Cos(c)) / s2 : Math.Sin(c);
            return 2 * c - 2 * tri;
        }

        // The half-angle at the axis of a cap of radius x between the other cap's axis (radius y, axes g apart)
        // and a point where the rims cross, from half-angle sines.
        static double CapHalfChord(double x, double y, double g)
        {
            double den = Math.Sin(x) * Math.Sin(g);
            double c = 1 + 2 * Math.Sin(0.5 * (g - x + y)) * Math.Sin(0.5 * (g - x - y)) / (den > 0 ? den : 1.0);
            return Math.Acos(Math.Min(1.0, Math.Max(-1.0, c)));
        }
    }
}
