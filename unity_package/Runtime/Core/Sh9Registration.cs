// Registration (docs/contract.md §13): where the 360° camera is in the headset's world, from a
// printed marker both of them see. Plain C#, no UnityEngine.
//
// The provider measures the marker's pose in the camera, R_camera←marker (columns: the marker's
// x = printed right, y = printed up, z = out of the printed face, OpenCV's ArUco axes) and its
// centre p_camera, in the wire frame (right-handed, +Y up). The headset's tracker gives the
// marker's pose in Unity's world: a Transform (rotation Q, position). Then, right-handed,
//   R_world←camera = R_world←marker · R_camera←markerᵀ,
// and Unity (left-handed, a direction (x, y, z) there is (x, y, −z) on the wire) gets it back as
// S·R_world←camera·S with S = diag(1, 1, −1). R_world←marker = S·R(Q)·C, where C holds the marker's
// OpenCV axes in the Transform's local axes (the tracker's convention, Sh9MarkerAxes): for a
// Unity quad-like marker (+X printed right, +Y printed up, the printed face toward local −Z) C = S,
// giving the S·R·S of the contract.
//
// Which convention each tracker reports (read at its source; unity_package/README.md §15 cites them):
//   AR Foundation ARTrackedImage (ARCore, ARKit): ImageInXZPlane, origin at the image's centre;
//   Vuforia image targets: +Y is the target's normal in Unity ("Other targets are left-handed and Y up");
//     with +X = printed right that is ImageInXZPlane (the top's direction is not stated there);
//   Microsoft QR codes (Microsoft.MixedReality.QR through a SpatialGraphNode): MicrosoftQrCode, origin at
//     the code's top-left corner (MarkerCentre moves it to the centre the provider measures).
using System;
using System.Collections.Generic;

namespace Shlight.Lighting
{
    /// <summary>Which local axes of the tracker's marker Transform are the printed marker's right, up
    /// and out-of-the-face directions.</summary>
    public enum Sh9MarkerAxes
    {
        /// <summary>Local +X = printed right, +Y = printed up, the printed face looks along local −Z
        /// (a Unity Quad showing the marker; a camera looking at it looks along the marker's +Z).</summary>
        QuadFacingMinusZ = 0,
        /// <summary>The marker lies in the local XZ plane: +X = printed right, +Z = printed up (toward the
        /// top edge), +Y = out of the printed face (the convention of image targets that lie in the
        /// XZ plane with +Y as their normal; check your tracker's documentation).</summary>
        ImageInXZPlane = 1,
        /// <summary>Microsoft's QR code frame in Unity (Microsoft.MixedReality.QR located through a
        /// SpatialGraphNode): origin at the code's top-left corner, +X = printed right, +Y = printed DOWN,
        /// +Z = out of the printed face (learn.microsoft.com "QR code tracking" for Unity: "the Z-axis points
        /// out of the paper and is left-handed"; microsoft/MixedReality-QRCode-Sample QRCode.cs:81 centres its
        /// cube at (+side/2, +side/2, 0)).</summary>
        MicrosoftQrCode = 2,
    }

    /// <summary>The "registration" of an sh9 message (immutable).</summary>
    public sealed class Sh9Registration
    {
        public string Marker, MarkerId;
        /// <summary>R_camera←marker, 9 numbers row-major (wire frame).</summary>
        public double[] Rotation;
        /// <summary>The marker's centre in the camera frame, metres (wire frame).</summary>
        public double[] Position;
        public double AgeSeconds, ErrorDegrees, ErrorPixels, SpreadDegrees;
        public int Frames;
        public bool Levelled;

        /// <summary>Parse the message's "registration" object (null when absent).</summary>
        public static Sh9Registration Parse(Dictionary<string, object> message)
        {
            object raw;
            if (!message.TryGetValue("registration", out raw) || raw == null) return null;
            var obj = raw as Dictionary<string, object>;
            if (obj == null) throw new FormatException("\"registration\" must be an object");
            var reg = new Sh9Registration
            {
                Marker = Sh9Protocol.GetString(obj, "marker", ""),
                MarkerId = Sh9Protocol.GetString(obj, "marker_id", ""),
                Rotation = Sh9Protocol.GetNumbers(obj, "rotation", 9, true),
                Position = Sh9Protocol.GetNumbers(obj, "position", 3, true),
                AgeSeconds = Sh9Protocol.GetNumber(obj, "age_s", 0),
                ErrorDegrees = Sh9Protocol.GetNumber(obj, "error_deg", double.NaN),
                ErrorPixels = Sh9Protocol.GetNumber(obj, "error_px", double.NaN),
                SpreadDegrees = Sh9Protocol.GetNumber(obj, "spread_deg", double.NaN),
                Frames = (int)Sh9Protocol.GetNumber(obj, "frames", 1),
                Levelled = Sh9Protocol.GetBool(obj, "levelled", false),
            };
            // a rotation: orthonormal with determinant +1 (to float rounding)
            double[] m = reg.Rotation;
            for (int a = 0; a < 3; a++)
                for (int b = 0; b < 3; b++)
                {
                    double dot = m[a] * m[b] + m[3 + a] * m[3 + b] + m[6 + a] * m[6 + b];
                    if (Math.Abs(dot - (a == b ? 1 : 0)) > 1e-4)
                        throw new FormatException("\"registration\".rotation is not a rotation matrix");
                }
            if (Sh9RegistrationMath.Determinant(m) < 0)
                throw new FormatException("\"registration\".rotation is a reflection, not a rotation");
            foreach (double v in reg.Position)
                if (double.IsNaN(v) || double.IsInfinity(v)) throw new FormatException("\"registration\".position is not finite");
            return reg;
        }
    }

    /// <summary>The composition of §13 in Unity's frame. Every method writes into arrays the caller
    /// keeps: none allocates.</summary>
    public static class Sh9RegistrationMath
    {
        public static double Determinant(double[] m)
        {
            return m[0] * (m[4] * m[8] - m[5] * m[7]) - m[1] * (m[3] * m[8] - m[5] * m[6]) + m[2] * (m[3] * m[7] - m[4] * m[6]);
        }

        /// <summary>C: the marker's OpenCV axes (columns) in the tracker Transform's local Unity axes.</summary>
        public static void MarkerAxesInLocal(Sh9MarkerAxes axes, double[] c)
        {
            Array.Clear(c, 0, 9);
            if (axes == Sh9MarkerAxes.ImageInXZPlane) { c[0] = 1; c[5] = 1; c[7] = 1; }   // x→X, y→Z, z→Y
            else if (axes == Sh9MarkerAxes.MicrosoftQrCode) { c[0] = 1; c[4] = -1; c[8] = 1; } // x→X, y→−Y, z→Z
            else { c[0] = 1; c[4] = 1; c[8] = -1; }                                          // x→X, y→Y, z→−Z
        }

        /// <summary>
        /// The marker's centre (what the provider's position refers to) in Unity's world, into
        /// <paramref name="centre"/> (3), from the tracked Transform's rotation (qx, qy, qz, qw) and position
        /// <paramref name="trackedPosition"/>: the same point, except for <see cref="Sh9MarkerAxes.MicrosoftQrCode"/>,
        /// whose origin is the code's top-left corner: centre = position + Q·(side/2, side/2, 0) (local +X is
        /// printed right, +Y printed down), <paramref name="sideMetres"/> the code's side (QRCode.PhysicalSideLength).
        /// Allocates nothing.
        /// </summary>
        public static void MarkerCentre(double qx, double qy, double qz, double qw, double[] trackedPosition,
                                        Sh9MarkerAxes axes, double sideMetres, double[] centre)
        {
            centre[0] = trackedPosition[0]; centre[1] = trackedPosition[1]; centre[2] = trackedPosition[2];
            if (axes != Sh9MarkerAxes.MicrosoftQrCode || !(sideMetres > 0)) return;
            double n = Math.Sqrt(qx * qx + qy * qy + qz * qz + qw * qw);
            if (!(n > 1e-12)) { qx = qy = qz = 0; qw = 1; n = 1; }
            qx /= n; qy /= n; qz /= n; qw /= n;
            double vx = sideMetres / 2, vy = sideMetres / 2, vz = 0;
            // v' = v + 2w(q×v) + 2q×(q×v)
            double tx = 2 * (qy * vz - qz * vy), ty = 2 * (qz * vx - qx * vz), tz = 2 * (qx * vy - qy * vx);
            centre[0] += vx + qw * tx + (qy * tz - qz * ty);
            centre[1] += vy + qw * ty + (qz * tx - qx * tz);
            centre[2] += vz + qw * tz + (qx * ty - qy * tx);
        }

        /// <summary>
        /// The probe's rotation in Unity's world (3×3 row-major, <paramref name="unityRotation"/>) and its
        /// quaternion (x, y, z, w) for a marker Transform of rotation (qx, qy, qz, qw) and position
        /// <paramref name="markerPosition"/> (Unity world), the marker axes convention, and the provider's
        /// R_camera←marker / p_camera (wire frame). <paramref name="cameraPosition"/> (3, may be null) gets
        /// where the camera is in Unity's world. <paramref name="scratch"/>: 27 doubles.
        /// </summary>
        public static void ProbeRotation(double qx, double qy, double qz, double qw, double[] markerPosition,
                                         Sh9MarkerAxes axes, double[] cameraFromMarker, double[] markerInCamera,
                                         double[] unityRotation, double[] quaternion, double[] cameraPosition,
                                         double[] scratch)
        {
            double[] s = scratch;                       // [0..8] R(Q), [9..17] C, [18..26] R_world←marker
            Sh9Math.QuaternionToMatrix(qx, qy, qz, qw, unityRotation);
            Array.Copy(unityRotation, 0, s, 0, 9);
            MarkerAxesInLocal(axes, unityRotation);     // C, kept in scratch[9..17]
            Array.Copy(unityRotation, 0, s, 9, 9);
            // R_world←marker = S·R(Q)·C (S negates row 2)
            for (int i = 0; i < 3; i++)
                for (int j = 0; j < 3; j++)
                {
                    double v = s[3 * i] * s[9 + j] + s[3 * i + 1] * s[12 + j] + s[3 * i + 2] * s[15 + j];
                    s[18 + 3 * i + j] = i == 2 ? -v : v;
                }
            // R_world←camera = R_wm · R_cmᵀ; Unity: S·R_wc·S (negate row 2 and column 2)
            double[] rc = cameraFromMarker;
            for (int i = 0; i < 3; i++)
                for (int j = 0; j < 3; j++)
                {
                    double v = s[18 + 3 * i] * rc[3 * j] + s[18 + 3 * i + 1] * rc[3 * j + 1] + s[18 + 3 * i + 2] * rc[3 * j + 2];
                    unityRotation[3 * i + j] = (i == 2) != (j == 2) ? -v : v;
                }
            MatrixToQuaternion(unityRotation, quaternion);
            if (cameraPosition != null && markerPosition != null && markerInCamera != null)
            {
                // p_camera (Unity) = marker position − R_U·(S·p_marker_in_camera)
                double px = markerInCamera[0], py = markerInCamera[1], pz = -markerInCamera[2];
                double[] u = unityRotation;
                cameraPosition[0] = markerPosition[0] - (u[0] * px + u[1] * py + u[2] * pz);
                cameraPosition[1] = markerPosition[1] - (u[3] * px + u[4] * py + u[5] * pz);
                cameraPosition[2] = markerPosition[2] - (u[6] * px + u[7] * py + u[8] * pz);
            }
        }

        /// <summary>Unit quaternion (x, y, z, w) of a rotation matrix (row-major), w ≥ 0.</summary>
        public static void MatrixToQuaternion(double[] m, double[] q)
        {
            double tr = m[0] + m[4] + m[8], x, y, z, w;
            if (tr > 0)
            {
                double k = Math.Sqrt(tr + 1.0) * 2;
                w = 0.25 * k; x = (m[7] - m[5]) / k; y = (m[2] - m[6]) / k; z = (m[3] - m[1]) / k;
            }
            else if (m[0] > m[4] && m[0] > m[8])
            {
                double k = Math.Sqrt(1.0 + m[0] - m[4] - m[8]) * 2;
                w = (m[7] - m[5]) / k; x = 0.25 * k; y = (m[1] + m[3]) / k; z = (m[2] + m[6]) / k;
            }
            else if (m[4] > m[8])
            {
                double k = Math.Sqrt(1.0 + m[4] - m[0] - m[8]) * 2;
                w = (m[2] - m[6]) / k; x = (m[1] + m[3]) / k; y = 0.25 * k; z = (m[5] + m[7]) / k;
            }
            else
            {
                double k = Math.Sqrt(1.0 + m[8] - m[0] - m[4]) * 2;
                w = (m[3] - m[1]) / k; x = (m[2] + m[6]) / k; y = (m[5] + m[7]) / k; z = 0.25 * k;
            }
            double n = Math.Sqrt(x * x + y * y + z * z + w * w);
            if (w < 0) n = -n;
            q[0] = x / n; q[1] = y / n; q[2] = z / n; q[3] = w / n;
        }
    }
}
