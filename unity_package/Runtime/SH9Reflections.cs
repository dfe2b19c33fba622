// Reflections of the real room: the provider's reflection cube (docs/contract.md §12), received by
// the SH9LightingClient on the same GameObject, baked into a Unity Cubemap (RGBAHalf, Unity's
// left-handed frame, Unity's mip ↔ roughness curve, turned by the same probe rotation as the
// SH9 lighting) and given to Unity as the default reflection (RenderSettings, Custom mode) or to a
// ReflectionProbe in Custom mode. Standard, URP Lit and MRTK Standard materials then reflect the room.
//
// The bake (Sh9UnityCubeBaker, ~33,000 texels for a 32² cube) runs on a thread of this component;
// Update only hands it work and copies finished texels into the Cubemap. Update allocates nothing
// in the steady state (measured under Mono by tests/csharp/ReflectionsClient.cs): the Cubemap is
// reused, its texels are written through GetPixelData (no copy of the array, no boxing), and the
// hand-over uses a lock and an AutoResetEvent.
using System;
using System.Threading;
using Unity.Collections;
using UnityEngine;
using UnityEngine.Rendering;

namespace Shlight.Lighting
{
    [AddComponentMenu("Lighting/SH9 Reflections (shlight)")]
    [RequireComponent(typeof(SH9LightingClient))]
    [DisallowMultipleComponent]
    public sealed class SH9Reflections : MonoBehaviour
    {
        [Tooltip("A Reflection Probe to drive (switched to Custom mode while enabled). Empty: the scene's " +
                 "default reflection (Lighting window → Environment Reflections) is set to Custom and driven.")]
        [SerializeField] ReflectionProbe reflectionProbe;
        [Tooltip("Re-bake when the probe's rotation changes by more than this (degrees); a 128² cube's texel is about 0.7°.")]
        [Range(0.05f, 10f)]
        [SerializeField] float rotationToleranceDegrees = 0.5f;

        SH9LightingClient lighting;
        Cubemap cubemap;
        // hand-over between Update and the bake thread (under gate)
        readonly object gate = new object();
        readonly AutoResetEvent wake = new AutoResetEvent(false);
        Thread worker;
        volatile bool stopping;
        Sh9EnvironmentSnapshot requested;          // what Update asked for last
        readonly double[] requestedRotation = new double[9];
        bool requestPending;
        Quaternion requestedQuaternion;
        ushort[] baked = new ushort[0];            // the newest finished bake, copied out of the worker's baker
        int bakedSize;
        long bakedSeq = -1;
        bool bakedReady;
        // what was there before (restored on disable)
        bool savedSettings;
        DefaultReflectionMode savedMode;
        Cubemap savedCustom;
        ReflectionProbeMode savedProbeMode;
        Texture savedProbeTexture;
        ReflectionProbe drivenProbe;

        /// <summary>The Cubemap given to Unity (null until the first cube has been baked).</summary>
        public Cubemap Cubemap { get { return cubemap; } }
        /// <summary>seq of the provider's cube shown now (-1 before the first).</summary>
        public long ShownSeq { get; private set; }
        /// <summary>Cubes uploaded to the Cubemap so far.</summary>
        public long Uploads { get; private set; }
        public ReflectionProbe ReflectionProbe { get { return reflectionProbe; } set { reflectionProbe = value; } }

        void OnEnable()
        {
            lighting = GetComponent<SH9LightingClient>();
            ShownSeq = -1;
            if (lighting != null) lighting.ReceiveEnvironment = true;
            stopping = false;
            worker = new Thread(BakeLoop) { IsBackground = true, Name = "shlight reflection bake" };
            worker.Start();
        }

        void OnDisable()
        {
            stopping = true;
            wake.Set();
            if (worker != null) worker.Join(2000);
            worker = null;
            if (lighting != null) lighting.ReceiveEnvironment = false;
            Restore();
            if (cubemap != null) Destroy(cubemap);
            cubemap = null;
            requested = null;
        }

        void Update()
        {
            if (lighting == null) return;
            Sh9EnvironmentSnapshot env = lighting.LatestEnvironment;
            Quaternion q = lighting.ProbeRotation;
            if (env != null && (!ReferenceEquals(env, requested) || AngleDegrees(q, requestedQuaternion) > rotationToleranceDegrees))
            {
                lock (gate)
                {
                    Sh9Math.QuaternionToMatrix(q.x, q.y, q.z, q.w, requestedRotation);
                    requested = env;
                    requestedQuaternion = q;
                    requestPending = true;
                }
                wake.Set();
            }
            lock (gate)
            {
                if (bakedReady)
                {
                    bakedReady = false;
                    Upload();
                }
            }
        }

        static float AngleDegrees(Quaternion a, Quaternion b)
        {
            double dot = Math.Abs((double)a.x * b.x + (double)a.y * b.y + (double)a.z * b.z + (double)a.w * b.w);
            return (float)(2 * Math.Acos(Math.Min(1.0, dot)) * 180 / Math.PI);
        }

        // Under gate: the finished texels into the Cubemap, level by level, face by face.
        void Upload()
        {
            if (cubemap == null || cubemap.width != bakedSize)
            {
                Cubemap old = cubemap;
                cubemap = new Cubemap(bakedSize, TextureFormat.RGBAHalf, Sh9UnityCubeBaker.Levels);
                cubemap.name = "shlight reflection cube";
                cubemap.filterMode = FilterMode.Trilinear;
                cubemap.wrapMode = TextureWrapMode.Clamp;
                Assign();
                if (old != null) Destroy(old);
            }
            for (int level = 0; level < Sh9UnityCubeBaker.Levels; level++)
            {
                int length = Sh9UnityCubeBaker.FaceLength(bakedSize, level);
                for (int face = 0; face < 6; face++)
                {
                    NativeArray<ushort> texels = cubemap.GetPixelData<ushort>(level, (CubemapFace)face);
                    NativeArray<ushort>.Copy(baked, Sh9UnityCubeBaker.Offset(bakedSize, level, face), texels, 0, length);
                }
            }
            cubemap.Apply(false, false);
            Uploads++;
            ShownSeq = bakedSeq;
            Assign();
        }

        // The Cubemap as the default reflection or the probe's custom texture (once; again if changed).
        void Assign()
        {
            if (reflectionProbe != null)
            {
                if (drivenProbe != reflectionProbe)
                {
                    Restore();
                    drivenProbe = reflectionProbe;
                    savedProbeMode = reflectionProbe.mode;
                    savedProbeTexture = reflectionProbe.customBakedTexture;
                }
                if (reflectionProbe.mode != ReflectionProbeMode.Custom) reflectionProbe.mode = ReflectionProbeMode.Custom;
                if (reflectionProbe.customBakedTexture != cubemap) reflectionProbe.customBakedTexture = cubemap;
                return;
            }
            if (drivenProbe != null) Restore();
            if (!savedSettings)
            {
                savedMode = RenderSettings.defaultReflectionMode;
                savedCustom = CustomReflection;
                savedSettings = true;
            }
            RenderSettings.defaultReflectionMode = DefaultReflectionMode.Custom;
            if (CustomReflection != cubemap) CustomReflection = cubemap;
        }

        // RenderSettings.customReflection (a Cubemap before 2021.2, a Texture in 2021) became
        // customReflectionTexture in 2022.1 (UnityCsReference, GraphicsManagers.bindings.cs).
        static Cubemap CustomReflection
        {
#if UNITY_2022_1_OR_NEWER
            get { return RenderSettings.customReflectionTexture as Cubemap; }
            set { RenderSettings.customReflectionTexture = value; }
#else
            get { return RenderSettings.customReflection as Cubemap; }
            set { RenderSettings.customReflection = value; }
#endif
        }

        void Restore()
        {
            if (drivenProbe != null)
            {
                drivenProbe.mode = savedProbeMode;
                drivenProbe.customBakedTexture = savedProbeTexture;
                drivenProbe = null;
            }
            if (savedSettings)
            {
                RenderSettings.defaultReflectionMode = savedMode;
                CustomReflection = savedCustom;
                savedSettings = false;
            }
        }

        // The bake thread: waits for a request, bakes it, copies the texels out for Update.
        void BakeLoop()
        {
            var baker = new Sh9UnityCubeBaker();
            var rotation = new double[9];
            while (true)
            {
                wake.WaitOne();
                if (stopping) return;
                Sh9EnvironmentSnapshot env;
                lock (gate)
                {
                    if (!requestPending) continue;
                    requestPending = false;
                    env = requested;
                    Array.Copy(requestedRotation, rotation, 9);
                }
                try
                {
                    baker.Bake(env.Cube, rotation);
                }
                catch (Exception e)
                {
                    Debug.LogError("[SH9] reflection cube not baked: " + e.Message);
                    continue;
                }
                lock (gate)
                {
                    if (baked.Length != baker.Data.Length) baked = new ushort[baker.Data.Length];
                    Array.Copy(baker.Data, baked, baked.Length);
                    bakedSize = baker.Size;
                    bakedSeq = env.Cube.Seq;
                    bakedReady = true;
                }
            }
        }
    }
}
