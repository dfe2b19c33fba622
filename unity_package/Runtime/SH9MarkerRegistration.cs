// Registration (docs/contract.md §13): places the 360° camera in the headset's world from a printed
// marker that both see. The provider measures the marker in the camera (the "registration" of each
// sh9 message); your tracker (HoloLens QR tracking, AR Foundation image tracking, Vuforia, OpenXR
// marker tracking, ...) moves a Transform to the marker in Unity's world; Marker Axes says which of its
// local axes are the printed marker's (per tracker: README §15, Runtime/Core/Sh9Registration.cs). This component turns the
// SH9LightingClient's transform so that the lighting (coefficients, Directional Light, reflection
// cube) arrives from the directions it came from in the room:
//   R_world←camera = R_world←marker · R_camera←markerᵀ   (right-handed; Unity: S·R·S, S = diag(1, 1, −1)).
// It runs before SH9LightingClient (DefaultExecutionOrder) and allocates nothing per frame.
using UnityEngine;

namespace Shlight.Lighting
{
    [AddComponentMenu("Lighting/SH9 Marker Registration (shlight)")]
    [DefaultExecutionOrder(-100)]
    [DisallowMultipleComponent]
    public sealed class SH9MarkerRegistration : MonoBehaviour
    {
        [Tooltip("The SH9 Lighting Client whose transform is turned (and moved to where the camera is).")]
        [SerializeField] SH9LightingClient lightingClient;
        [Tooltip("The Transform your tracker keeps on the printed marker.")]
        [SerializeField] Transform marker;
        [Tooltip("Which local axes of that Transform are the printed marker's right, up and out-of-the-face directions.")]
        [SerializeField] Sh9MarkerAxes markerAxes = Sh9MarkerAxes.QuadFacingMinusZ;
        [Tooltip("Microsoft QR codes only: the code's side in metres (QRCode.PhysicalSideLength). Their origin is the " +
                 "top-left corner; this moves it to the centre the provider measures (position only).")]
        [SerializeField] float markerSideMetres = 0f;
        [Tooltip("Use the server's registration only when its marker_id is this (empty: any).")]
        [SerializeField] string markerId = "";
        [Tooltip("Also move the client's transform to where the camera is (for gizmos; the lighting needs only the rotation).")]
        [SerializeField] bool movePosition = true;

        readonly double[] unityRotation = new double[9];
        readonly double[] quaternion = new double[4];
        readonly double[] cameraPosition = new double[3];
        readonly double[] markerPosition = new double[3];
        readonly double[] markerCentre = new double[3];
        readonly double[] scratch = new double[27];
        Sh9Registration manual;

        public Transform Marker { get { return marker; } set { marker = value; } }
        public SH9LightingClient LightingClient { get { return lightingClient; } set { lightingClient = value; } }
        public Sh9MarkerAxes MarkerAxes { get { return markerAxes; } set { markerAxes = value; } }
        /// <summary>The QR code's side in metres for <see cref="Sh9MarkerAxes.MicrosoftQrCode"/> (corner → centre).</summary>
        public float MarkerSideMetres { get { return markerSideMetres; } set { markerSideMetres = value; } }
        /// <summary>True once a registration has oriented the lighting.</summary>
        public bool Registered { get; private set; }
        /// <summary>The registration used last (the server's, or the one given to <see cref="UseRegistration"/>).</summary>
        public Sh9Registration Current { get; private set; }

        /// <summary>Use a fixed registration (e.g. `shlight register` output: rotation row-major, position
        /// in metres, wire frame) instead of the server's; null goes back to the server's.</summary>
        public void UseRegistration(Sh9Registration registration) { manual = registration; }

        void Reset() { lightingClient = GetComponent<SH9LightingClient>(); }

        void Update()
        {
            SH9LightingClient client = lightingClient != null ? lightingClient : GetComponent<SH9LightingClient>();
            if (client == null || marker == null) return;
            Sh9Registration reg = manual;
            if (reg == null)
            {
                Sh9Message message = client.LastMessage;
                reg = message == null ? null : message.Registration;
                if (reg != null && !string.IsNullOrEmpty(markerId) && reg.MarkerId != markerId) reg = null;
            }
            if (reg == null) return;
            Quaternion q = marker.rotation;
            Vector3 p = marker.position;
            markerPosition[0] = p.x; markerPosition[1] = p.y; markerPosition[2] = p.z;
            Sh9RegistrationMath.MarkerCentre(q.x, q.y, q.z, q.w, markerPosition, markerAxes, markerSideMetres, markerCentre);
            Sh9RegistrationMath.ProbeRotation(q.x, q.y, q.z, q.w, markerCentre, markerAxes, reg.Rotation, reg.Position,
                                              unityRotation, quaternion, cameraPosition, scratch);
            Transform t = client.transform;
            t.rotation = new Quaternion((float)quaternion[0], (float)quaternion[1], (float)quaternion[2], (float)quaternion[3]);
            if (movePosition)
                t.position = new Vector3((float)cameraPosition[0], (float)cameraPosition[1], (float)cameraPosition[2]);
            Current = reg;
            Registered = true;
        }
    }
}
