// Puts a hologram's bounding sphere where the shadow catchers read it (issue 30; docs/shadows_consumers.md):
// the global _SHOccluderSphere (xyz: centre, w: radius, world space), from which "Shlight/SH9 Shadow Catcher"
// (built-in) and "Shlight/SH9 Shadow Catcher (URP)" take off the ambient the hologram hides from the floor
// under it (SHOccludedAmbientOfSphere, SHShadowRatioOccluded in sh9_lights.hlsl). Without it the catchers
// darken by the key light's shadow alone, and a hologram close to the floor looks lighter underneath than
// the room would make it (docs/shadows.md measures by how much).
//
// The sphere bounds the renderers under this GameObject (its own included), taken when enabled (call
// Refresh() after adding or removing parts), re-measured every LateUpdate (after animation) from their
// world bounds: centre the union box's centre, radius half its diagonal. One occluder per scene: the
// global is shared, so the last enabled SH9ShadowOccluder wins; disabling the one that set it clears it.
using UnityEngine;

namespace Shlight.Lighting
{
    [AddComponentMenu("Lighting/SH9 Shadow Occluder (shlight)")]
    [DisallowMultipleComponent]
    public sealed class SH9ShadowOccluder : MonoBehaviour
    {
        /// <summary>The global the catchers read.</summary>
        public const string OccluderSphereProperty = "_SHOccluderSphere";
        static readonly int OccluderSphereId = Shader.PropertyToID(OccluderSphereProperty);
        static SH9ShadowOccluder current;

        [Tooltip("Scales the bounding sphere's radius (1: the sphere around the renderers' bounds; a round hologram " +
                 "fills it, a flat or thin one less: lower it toward the radius of the hologram's bulk).")]
        [SerializeField] [Range(0.1f, 2f)] float radiusScale = 1f;

        Renderer[] renderers = new Renderer[0];
        readonly double[] sphere = new double[4];

        /// <summary>The sphere last uploaded (x, y, z, radius; radius 0: none), world space.</summary>
        public Vector4 Sphere { get; private set; }

        public float RadiusScale { get { return radiusScale; } set { radiusScale = value; } }

        /// <summary>Gathers the renderers under this GameObject again (active ones).</summary>
        public void Refresh() { renderers = GetComponentsInChildren<Renderer>(false); }

        void OnEnable()
        {
            Refresh();
            current = this;
            LateUpdate();
        }

        void OnDisable()
        {
            if (current != this) return;
            current = null;
            Sphere = new Vector4(0, 0, 0, 0);
            Shader.SetGlobalVector(OccluderSphereId, Sphere);
        }

        void LateUpdate()
        {
            if (current != this) return;
            bool any = false;
            Vector3 min = Vector3.zero, max = Vector3.zero;
            foreach (Renderer r in renderers)
            {
                if (r == null || !r.enabled) continue;
                Bounds b = r.bounds;
                Vector3 lo = b.min, hi = b.max;
                if (!any) { min = lo; max = hi; any = true; continue; }
                min = new Vector3(System.Math.Min(min.x, lo.x), System.Math.Min(min.y, lo.y), System.Math.Min(min.z, lo.z));
                max = new Vector3(System.Math.Max(max.x, hi.x), System.Math.Max(max.y, hi.y), System.Math.Max(max.z, hi.z));
            }
            if (any)
            {
                Sh9Shadows.BoundingSphere(min.x, min.y, min.z, max.x, max.y, max.z, sphere);
                Sphere = new Vector4((float)sphere[0], (float)sphere[1], (float)sphere[2], (float)(sphere[3] * radiusScale));
            }
            else
            {
                Sphere = new Vector4(0, 0, 0, 0);
            }
            Shader.SetGlobalVector(OccluderSphereId, Sphere);
        }
    }
}
