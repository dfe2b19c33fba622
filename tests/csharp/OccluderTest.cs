// Drives SH9ShadowOccluder (the package's MonoBehaviour; issue 30) through OnEnable / LateUpdate / OnDisable
// on a scene built with tests/unity_stubs/UnityEngineStandIn.cs -- a compile-only stand-in for UnityEngine,
// NOT Unity: renderers whose world bounds the test sets. Checks the global _SHOccluderSphere the shadow
// catchers read: the bounding sphere of the renderers' union box, following them, a disabled renderer left
// out, the radius scale, and cleared when the component is disabled. Prints Checks' one-line JSON report.
using System;
using System.Reflection;
using Shlight.Lighting;
using UnityEngine;

static class OccluderTest
{
    static readonly Checks checks = new Checks(1.0);

    static void Call(object target, string method)
    {
        target.GetType().GetMethod(method, BindingFlags.Instance | BindingFlags.NonPublic | BindingFlags.Public)
              .Invoke(target, null);
    }

    static double[] Global()
    {
        Vector4 v;
        if (!Shader.StandInGlobalVectors.TryGetValue(Shader.PropertyToID("_SHOccluderSphere"), out v))
            return new double[] { double.NaN, double.NaN, double.NaN, double.NaN };
        return new double[] { v.x, v.y, v.z, v.w };
    }

    static Renderer Part(Transform parent, Vector3 centre, Vector3 size)
    {
        var g = GameObject.CreatePrimitive(PrimitiveType.Cube);
        g.transform.SetParent(parent, false);
        Renderer r = g.GetComponent<Renderer>();
        r.StandInBounds = new Bounds(centre, size);
        return r;
    }

    static int Main()
    {
        try
        {
            var hologram = new GameObject("Hologram");
            var body = hologram.AddComponent<MeshRenderer>();
            body.StandInBounds = new Bounds(new Vector3(0, 1, 0), new Vector3(1, 1, 1));     // box 0.5..1.5 in y
            Renderer arm = Part(hologram.transform, new Vector3(1, 1, 0), new Vector3(1, 0.2f, 0.2f));
            var occluder = hologram.AddComponent<SH9ShadowOccluder>();
            Call(occluder, "OnEnable");
            // union box x -0.5..1.5, y 0.5..1.5, z -0.5..0.5: centre (0.5, 1, 0), radius |(1, 0.5, 0.5)|
            double r = Math.Sqrt(1 + 0.25 + 0.25);
            checks.Compare("union_sphere", Global(), new[] { 0.5, 1.0, 0.0, r }, 1e-6, "body + arm");
            arm.StandInBounds = new Bounds(new Vector3(0, 3, 0), new Vector3(1, 1, 1));       // the arm moved up: y 0.5..3.5
            Call(occluder, "LateUpdate");
            checks.Compare("follows", Global(), new[] { 0.0, 2.0, 0.0, Math.Sqrt(0.25 + 2.25 + 0.25) }, 1e-6,
                           "arm moved to y = 3");
            arm.enabled = false;
            Call(occluder, "LateUpdate");
            checks.Compare("disabled_renderer_left_out", Global(), new[] { 0.0, 1.0, 0.0, Math.Sqrt(0.75) }, 1e-6,
                           "body alone");
            occluder.RadiusScale = 0.5f;
            Call(occluder, "LateUpdate");
            checks.Compare("radius_scale", Global(), new[] { 0.0, 1.0, 0.0, 0.5 * Math.Sqrt(0.75) }, 1e-6, "scale 0.5");
            Call(occluder, "OnDisable");
            checks.Compare("cleared_on_disable", Global(), new[] { 0.0, 0.0, 0.0, 0.0 }, 0, "radius 0: no occluder");
            // a second occluder enabled later wins; disabling the first then leaves the second's sphere
            Call(occluder, "OnEnable");
            var other = new GameObject("Other");
            other.AddComponent<MeshRenderer>().StandInBounds = new Bounds(new Vector3(5, 0.5f, 5), new Vector3(1, 1, 1));
            var second = other.AddComponent<SH9ShadowOccluder>();
            Call(second, "OnEnable");
            Call(occluder, "LateUpdate");
            Call(occluder, "OnDisable");
            checks.Compare("last_enabled_wins", Global(), new[] { 5.0, 0.5, 5.0, Math.Sqrt(0.75) }, 1e-6, "second");
            var empty = new GameObject("Empty").AddComponent<SH9ShadowOccluder>();
            Call(empty, "OnEnable");
            checks.Compare("no_renderers_no_occluder", Global(), new[] { 0.0, 0.0, 0.0, 0.0 }, 0, "empty");
        }
        catch (Exception e)
        {
            checks.Fail("exception: " + e);
        }
        return checks.Report(7);
    }
}
