// Issue 31, consumers: from an "sh9" message's photometry (docs/contract.md §14) to what a Unity render
// pipeline takes: the exposure (a scale on the SH9 and light for URP/built-in, an EV100 for an HDRP
// physical camera), the drawn light's colour from its colour temperature, and its intensity in the
// pipeline's units. Plain C#, no UnityEngine: SH9LightingClient applies it, the Mono tests check it
// (tests/clients/unity/test_unity_exposure.py). Formulas and units: docs/unity.md, "Exposure, colour temperature".
using System;

namespace Shlight.Lighting
{
    /// <summary>How a consumer (SH9LightingClient's Exposure Mode) exposes the room's light.</summary>
    public enum Sh9ExposureMode
    {
        /// <summary>As before issue 31 (the default): the coefficients as sent × Intensity, whatever their units.</summary>
        Relative = 0,
        /// <summary>URP / built-in (Quest 3, Android XR passthrough): absolute lighting (cd/m², lux) is multiplied
        /// by the exposure 2^c / (1.2 · 2^EV100), so that a surface renders at the brightness a camera exposed
        /// for the room gives it (the room's mean luminance at 12.5 / 120 of white). Relative lighting stays as
        /// sent.</summary>
        CameraImage = 1,
        /// <summary>HDRP: the SH9 stays in lux and the drawn directional light is in lux (HDRP's Lambert has the
        /// 1/π that Unity's built-in/URP Lambert lacks); the camera takes the EV100 (EV100 − c). Relative
        /// lighting: the SH9 as sent, the light still in HDRP's convention (E, not E/π), no EV100.</summary>
        PhysicalCamera = 2,
        /// <summary>A video see-through headset whose camera the server has fitted (docs/passthrough.md): the SH9
        /// and the light as sent (the sphere's units, as Relative), then in SH9 Diffuse the hologram's linear colour
        /// × the view's exposure · white balance (× 2^c) goes through the headset camera's curve to the code its
        /// real replica shows in passthrough (Sh9PassthroughCamera's display lookup, SH9_PASSTHROUGH).</summary>
        Passthrough = 3,
    }

    /// <summary>What one message asks of the pipeline for a given <see cref="Sh9ExposureMode"/> (a struct:
    /// resolving it per message allocates nothing).</summary>
    public struct Sh9Exposure
    {
        /// <summary>True when the message is absolute ("cd/m²" with an EV100) and the mode uses it.</summary>
        public bool Applied;
        /// <summary>Multiplier on the SH9 irradiance and the light's irradiance before the user's Intensity:
        /// 2^c / (1.2 · 2^EV100) in <see cref="Sh9ExposureMode.CameraImage"/> with absolute lighting, 1
        /// otherwise. Units: 1/(cd/m²) → the camera image's linear value per cd/m².</summary>
        public double Scale;
        /// <summary>The EV100 (ISO 100 exposure value, log2 of N²/t at ISO 100) a physical camera should use:
        /// EV100 − c in <see cref="Sh9ExposureMode.PhysicalCamera"/> with absolute lighting; NaN otherwise.</summary>
        public double CameraEv100;
        /// <summary>What a directional light's colour × intensity is per unit of irradiance: 1/π for Unity's
        /// built-in and URP Lambert (albedo × light × N·L, no 1/π: the light carries E/π, the SH9 convention
        /// ρE/π), 1 for HDRP (its Lambert divides by π itself: a directional light's intensity is lux).</summary>
        public double LightFactor;

        /// <summary>The exposure of <paramref name="message"/> for <paramref name="mode"/>, with an exposure
        /// compensation of <paramref name="compensationEv"/> stops (+1: twice as bright).</summary>
        public static Sh9Exposure Resolve(Sh9Message message, Sh9ExposureMode mode, double compensationEv)
        {
            var e = new Sh9Exposure
            {
                Scale = 1.0,
                CameraEv100 = double.NaN,
                LightFactor = mode == Sh9ExposureMode.PhysicalCamera ? 1.0 : 1.0 / Math.PI,
            };
            if (message == null || !message.IsAbsolute || mode == Sh9ExposureMode.Relative ||
                mode == Sh9ExposureMode.Passthrough) return e;
            if (double.IsNaN(compensationEv) || double.IsInfinity(compensationEv)) compensationEv = 0;
            double ev = message.Ev100 - compensationEv;
            if (mode == Sh9ExposureMode.CameraImage)
            {
                e.Scale = Sh9Photometry.ExposureFromEv100(ev);
                e.Applied = true;
            }
            else if (mode == Sh9ExposureMode.PhysicalCamera)
            {
                e.CameraEv100 = ev;
                e.Applied = true;
            }
            return e;
        }

        /// <summary>The shutter time (seconds) that gives <paramref name="ev100"/> at f-number
        /// <paramref name="aperture"/> and ISO <paramref name="iso"/>: t = N² · (100 / S) / 2^EV100 (EV100 =
        /// log2(N²/t) − log2(S/100)); what a camera's physical properties take. NaN for invalid input.</summary>
        public static double ShutterSeconds(double ev100, double aperture, double iso)
        {
            if (double.IsNaN(ev100) || double.IsInfinity(ev100) || !(aperture > 0) || !(iso > 0)) return double.NaN;
            return aperture * aperture * (100.0 / iso) / Math.Pow(2.0, ev100);
        }

        /// <summary>EV100 = log2(N² / t · 100 / S) of a camera at f-number N, shutter t seconds, ISO S.</summary>
        public static double Ev100FromCamera(double aperture, double shutterSeconds, double iso)
        {
            if (!(aperture > 0) || !(shutterSeconds > 0) || !(iso > 0)) return double.NaN;
            return Math.Log(aperture * aperture / shutterSeconds * 100.0 / iso, 2.0);
        }
    }

    /// <summary>The drawn light's colour from its colour temperature.</summary>
    public static class Sh9LightTemperature
    {
        /// <summary>Rec. 709 luminance of linear RGB (docs/photometry.md).</summary>
        public static double Luminance(double r, double g, double b)
        {
            return 0.2126 * r + 0.7152 * g + 0.0722 * b;
        }

        /// <summary>The colour temperature (kelvin) for light <paramref name="drawnLight"/> of the message: its
        /// <c>light_cct_k</c> when it has one (> 0), else the ambient's <c>cct_k</c>, else NaN (no CCT: keep the
        /// colour from RGB).</summary>
        public static double KeyLightCctK(Sh9Message message, int drawnLight)
        {
            if (message == null) return double.NaN;
            double[] k = message.LightCctK;
            if (k != null && drawnLight >= 0 && drawnLight < k.Length && Usable(k[drawnLight])) return k[drawnLight];
            return Usable(message.CctK) ? message.CctK : double.NaN;
        }

        static bool Usable(double kelvin)
        {
            return kelvin > 0 && !double.IsInfinity(kelvin);
        }

        /// <summary>
        /// A directional light's (colour, intensity) in <paramref name="rgbi"/> (colour sRGB-encoded as
        /// Unity's Light.color is, intensity in [3]) that shows the linear light colour (r, g, b) — what the
        /// shaders should see, e.g. E/π — in colour space <paramref name="space"/>.
        /// With a colour temperature (<paramref name="kelvin"/> usable, <paramref name="space"/> linear with
        /// linear intensity, which Unity's temperature needs) the colour is white and the intensity
        /// Y(r, g, b) / Y(kr, kg, kb), where (kr, kg, kb) is the engine's linear RGB for that temperature
        /// (Mathf.CorrelatedColorTemperatureToRGB): the luminance is kept, the chromaticity is the
        /// temperature's. Returns true then; false when the colour comes from RGB (as before).
        /// </summary>
        public static bool LightColor(double r, double g, double b, Sh9LightColorSpace space, double kelvin,
                                      double kr, double kg, double kb, double[] rgbi)
        {
            if (rgbi == null || rgbi.Length != 4) throw new ArgumentException("rgbi must have 4 values");
            double yk = Luminance(kr, kg, kb);
            if (space == Sh9LightColorSpace.LinearIntensity && Usable(kelvin) && yk > 0)
            {
                rgbi[0] = rgbi[1] = rgbi[2] = 1.0;
                rgbi[3] = Math.Max(0, Luminance(Math.Max(0, r), Math.Max(0, g), Math.Max(0, b))) / yk;
                return true;
            }
            Sh9Math.LightColorFromLinear(r, g, b, space, rgbi);
            return false;
        }
    }
}
