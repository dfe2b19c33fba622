// Issue 31, consumers: the package's core turns a message's photometry into what a Unity pipeline takes
// (Sh9Exposure, Sh9LightTemperature; docs/unity.md). One case per stdin line:
//   MODE COMPENSATION_EV APERTURE ISO COLOR_SPACE KELVIN_R KELVIN_G KELVIN_B <TAB> sh9 message JSON
// (MODE relative|camera_image|physical_camera; COLOR_SPACE linear_intensity|gamma_intensity|gamma; KELVIN_RGB
// the engine's linear RGB for the light's temperature, as Mathf.CorrelatedColorTemperatureToRGB gives it).
// Prints one JSON object per case: the exposure, the camera settings, what a white Lambertian surface facing +Y
// shows from the SH9 (radiance, E/π), and the drawn light as set and as the shaders see it (linear).
using System;
using System.Globalization;
using System.Text;
using Shlight.Lighting;

static class ExposureTest
{
    static string N(double v)
    {
        return double.IsNaN(v) || double.IsInfinity(v) ? "null" : v.ToString("R", CultureInfo.InvariantCulture);
    }

    static string Array(double[] v)
    {
        var sb = new StringBuilder("[");
        for (int i = 0; i < v.Length; i++) sb.Append(i > 0 ? ", " : "").Append(N(v[i]));
        return sb.Append(']').ToString();
    }

    static double D(string s)
    {
        return double.Parse(s, CultureInfo.InvariantCulture);
    }

    static int Main()
    {
        string line;
        while ((line = Console.In.ReadLine()) != null)
        {
            if (line.Trim().Length == 0) continue;
            int tab = line.IndexOf('\t');
            string[] a = line.Substring(0, tab).Split(' ');
            var mode = a[0] == "camera_image" ? Sh9ExposureMode.CameraImage
                     : a[0] == "physical_camera" ? Sh9ExposureMode.PhysicalCamera : Sh9ExposureMode.Relative;
            double compensation = D(a[1]), aperture = D(a[2]), iso = D(a[3]);
            var space = a[4] == "gamma_intensity" ? Sh9LightColorSpace.GammaIntensity
                      : a[4] == "gamma" ? Sh9LightColorSpace.Gamma : Sh9LightColorSpace.LinearIntensity;
            double kr = D(a[5]), kg = D(a[6]), kb = D(a[7]);
            Sh9Message m = Sh9Protocol.Parse(line.Substring(tab + 1)).Sh9;

            // what SH9LightingClient.Update does with a message
            Sh9Exposure e = Sh9Exposure.Resolve(m, mode, compensation);
            var snap = new Sh9Snapshot(m, 0, 1, 0);
            var values = new Sh9LightingValues();
            values.Set(snap, 0, 0, 0, 1, e.Scale, true);
            double[] up = values.Irradiance(0, 1, 0);
            for (int c = 0; c < 3; c++) up[c] /= Math.PI;

            double kelvin = Sh9LightTemperature.KeyLightCctK(m, snap.DrawnLight);
            var rgbi = new double[4];
            double[] li = values.LightIrradiance;
            bool temperature = Sh9LightTemperature.LightColor(li[0] * e.LightFactor, li[1] * e.LightFactor,
                                                              li[2] * e.LightFactor, space, kelvin, kr, kg, kb, rgbi);
            // what the shaders see: Unity's (colour, intensity[, temperature]) → linear light colour
            var seen = new double[3];
            for (int c = 0; c < 3; c++)
            {
                double k = c == 0 ? kr : c == 1 ? kg : kb;
                if (temperature) seen[c] = Sh9Math.GammaToLinearExact(rgbi[c]) * rgbi[3] * k;
                else if (space == Sh9LightColorSpace.LinearIntensity) seen[c] = Sh9Math.GammaToLinearExact(rgbi[c]) * rgbi[3];
                else if (space == Sh9LightColorSpace.GammaIntensity) seen[c] = Sh9Math.GammaToLinearExact(rgbi[c] * rgbi[3]);
                else seen[c] = rgbi[c] * rgbi[3];
            }
            double shutter = Sh9Exposure.ShutterSeconds(e.CameraEv100, aperture, iso);

            var sb = new StringBuilder();
            sb.Append("{\"absolute\": ").Append(m.IsAbsolute ? "true" : "false");
            sb.Append(", \"applied\": ").Append(e.Applied ? "true" : "false");
            sb.Append(", \"scale\": ").Append(N(e.Scale));
            sb.Append(", \"camera_ev100\": ").Append(N(e.CameraEv100));
            sb.Append(", \"light_factor\": ").Append(N(e.LightFactor));
            sb.Append(", \"shutter_s\": ").Append(N(shutter));
            sb.Append(", \"camera_ev100_back\": ").Append(N(Sh9Exposure.Ev100FromCamera(aperture, shutter, iso)));
            sb.Append(", \"up_radiance\": ").Append(Array(up));
            sb.Append(", \"light_active\": ").Append(values.LightActive ? "true" : "false");
            sb.Append(", \"kelvin\": ").Append(N(kelvin));
            sb.Append(", \"temperature\": ").Append(temperature ? "true" : "false");
            sb.Append(", \"light_rgbi\": ").Append(Array(rgbi));
            sb.Append(", \"light_seen\": ").Append(Array(seen));
            sb.Append('}');
            Console.WriteLine(sb.ToString());
        }
        return 0;
    }
}
