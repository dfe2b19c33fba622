// Lights one renderer with the light where it stands (docs/probes.md "In the engines"), for renderers that
// do not blend Unity's light probes (or scenes without a SH9ProbeGrid): subscribes over the WebSocket to the
// light at this transform's position (converted to the wire's frame) and hands it to the renderer as its own
// light probe (LightProbeUsage.CustomProvided + MaterialPropertyBlock.CopySHCoefficientArraysFrom), which
// Unity's shaders read as unity_SHAr..unity_SHC: no shader change. Re-subscribes when the transform has
// moved moveThreshold metres. The server needs several positioned probes (docs/probes.md).
using UnityEngine;
using UnityEngine.Rendering;

namespace Shlight.Lighting
{
    [AddComponentMenu("Lighting/SH9 Point Light (shlight)")]
    [DisallowMultipleComponent]
    public sealed class SH9PointLight : SH9ServerComponent
    {
        [Tooltip("The renderer to light (this GameObject's if empty).")]
        [SerializeField] Renderer target;
        [Tooltip("Metres the transform moves before the light is asked for where it is now.")]
        [Min(0.01f)] [SerializeField] float moveThreshold = 0.25f;

        Sh9PointClient points;
        Renderer lit;
        LightProbeUsage savedUsage;
        MaterialPropertyBlock block;
        readonly SphericalHarmonicsL2[] probe = new SphericalHarmonicsL2[1];
        Vector3 subscribedAt;
        long appliedVersion;

        public Renderer Target { get { return target; } set { target = value; } }
        public float MoveThreshold { get { return moveThreshold; } set { moveThreshold = value; } }
        /// <summary>The subscription (null while disabled): its light, position and last error.</summary>
        public Sh9PointClient Points { get { return points; } }

        void OnEnable()
        {
            lit = target != null ? target : GetComponent<Renderer>();
            if (lit == null)
            {
                Debug.LogWarning("SH9PointLight: no renderer to light on " + name);
                enabled = false;
                return;
            }
            block = new MaterialPropertyBlock();
            appliedVersion = 0;
            points = new Sh9PointClient(UsedServerUrl, UsedToken, UsedTokenInQuery);
            Subscribe();
            points.Start();
        }

        void Subscribe()
        {
            subscribedAt = transform.position;
            // Unity's frame -> the wire's: z negated (docs/contract.md §1)
            points.MoveTo(subscribedAt.x, subscribedAt.y, -subscribedAt.z);
        }

        void Update()
        {
            if (points == null) return;
            Vector3 d = transform.position - subscribedAt;
            if (d.x * d.x + d.y * d.y + d.z * d.z >= moveThreshold * moveThreshold) Subscribe();
            long v = points.Version;
            if (v == appliedVersion) return;
            double[] values = points.UnityProbe;
            if (values == null) return;
            appliedVersion = v;
            for (int c = 0; c < 3; c++)
                for (int k = 0; k < 9; k++)
                    probe[0][c, k] = (float)values[9 * c + k];
            if (lit.lightProbeUsage != LightProbeUsage.CustomProvided)
            {
                savedUsage = lit.lightProbeUsage;
                lit.lightProbeUsage = LightProbeUsage.CustomProvided;
            }
            lit.GetPropertyBlock(block);
            block.CopySHCoefficientArraysFrom(probe);
            lit.SetPropertyBlock(block);
        }

        void OnDisable()
        {
            if (points != null) { points.Dispose(); points = null; }
            if (lit != null && appliedVersion != 0)
            {
                lit.lightProbeUsage = savedUsage;
                lit.SetPropertyBlock(null);
            }
        }
    }
}
