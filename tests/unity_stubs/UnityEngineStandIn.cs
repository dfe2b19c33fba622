// COMPILE-ONLY STAND-IN FOR UnityEngine -- NOT UNITY.
//
// The UnityEngine members that the package's MonoBehaviours, its sample and the test harnesses
// use, so that Mono's mcs can type-check them on a machine without Unity and a harness can drive
// them. The declarations mirror the Unity 2020.3 scripting API (as documented, and as declared in
// Unity-Technologies/UnityCsReference, branch 2020.3): properties where Unity has properties (so
// `RenderSettings.ambientProbe[0, 0] = x` or `transform.rotation.x = y` fail with CS1612 here as
// they do in Unity), value types as structs of plain fields (Matrix4x4 m00..m33,
// SphericalHarmonicsL2's 27 floats, Color, Vector3, Quaternion), the same generic constraints,
// overloads and enum values. Behaviour is a trivial model: setters store what they get so that a
// test can read it back, and nothing here allocates on the paths a frame takes (the harness measures
// the component's allocations). Members named StandIn* exist only here, for the harnesses.
// Nothing that runs against this file has run in Unity, and no test claims so.
using System;
using System.Collections.Generic;

namespace UnityEngine
{
    public class Object
    {
        // Stand-in only: every live object, for FindObjectsOfType.
        static readonly List<Object> standInLive = new List<Object>();
        bool destroyed;
        string objectName = "";

        public Object() { standInLive.Add(this); }

        public string name { get { return objectName; } set { objectName = value ?? ""; } }

        public static T FindObjectOfType<T>() where T : Object
        {
            foreach (Object o in standInLive) { var t = o as T; if (t != null) return t; }
            return null;
        }

        public static T[] FindObjectsOfType<T>() where T : Object
        {
            var found = new List<T>();
            foreach (Object o in standInLive) { var t = o as T; if (t != null) found.Add(t); }
            return found.ToArray();
        }

        public static void Destroy(Object obj)
        {
            if (obj == null) return;
            obj.destroyed = true;
            standInLive.Remove(obj);
        }

        // Unity's == treats a destroyed object as null (UnityEngineObject.bindings.cs, CompareBaseObjects).
        public static bool operator ==(Object x, Object y)
        {
            bool xNull = ReferenceEquals(x, null) || x.destroyed, yNull = ReferenceEquals(y, null) || y.destroyed;
            if (xNull || yNull) return xNull && yNull;
            return ReferenceEquals(x, y);
        }
        public static bool operator !=(Object x, Object y) { return !(x == y); }
        public static implicit operator bool(Object exists) { return exists != null; }
        public override bool Equals(object other) { return ReferenceEquals(this, other); }
        public override int GetHashCode() { return base.GetHashCode(); }
    }

    public class Component : Object
    {
        internal GameObject owner;
        Transform ownTransform;

        public Transform transform
        {
            get
            {
                if (owner != null) return owner.transform;
                if (ownTransform == null) ownTransform = this as Transform ?? new Transform();
                return ownTransform;
            }
        }

        public GameObject gameObject { get { return owner; } }

        public T GetComponent<T>() { return owner == null ? default(T) : owner.GetComponent<T>(); }

        public T[] GetComponentsInChildren<T>(bool includeInactive)
        {
            return owner == null ? new T[0] : owner.GetComponentsInChildren<T>(includeInactive);
        }
    }

    public class Behaviour : Component
    {
        bool isEnabled = true;
        public bool enabled { get { return isEnabled; } set { isEnabled = value; } }
        public bool isActiveAndEnabled { get { return isEnabled; } }
    }

    public class MonoBehaviour : Behaviour { }

    public class Transform : Component
    {
        Quaternion worldRotation = Quaternion.identity;
        Vector3 worldPosition, local, scale = new Vector3(1, 1, 1);
        Transform parent;
        internal readonly List<Transform> children = new List<Transform>();

        public Quaternion rotation { get { return worldRotation; } set { worldRotation = value; } }
        public Vector3 position { get { return worldPosition; } set { worldPosition = value; } }
        public Vector3 localPosition { get { return local; } set { local = value; } }
        public Vector3 localScale { get { return scale; } set { scale = value; } }
        /// <summary>rotation * Vector3.forward, as in Unity.</summary>
        public Vector3 forward { get { return worldRotation * Vector3.forward; } }

        public void SetParent(Transform p, bool worldPositionStays)
        {
            if (parent != null) parent.children.Remove(this);
            parent = p;
            if (p != null) p.children.Add(this);
        }
    }

    public sealed class GameObject : Object
    {
        readonly Transform ownTransform;
        readonly List<Component> components = new List<Component>();

        public GameObject(string name)
        {
            this.name = name;
            ownTransform = new Transform();
            ownTransform.owner = this;
            components.Add(ownTransform);
        }

        public Transform transform { get { return ownTransform; } }

        public T AddComponent<T>() where T : Component
        {
            var c = (T)Activator.CreateInstance(typeof(T));
            c.owner = this;
            components.Add(c);
            return c;
        }

        public T GetComponent<T>()
        {
            foreach (Component c in components) if (c is T) return (T)(object)c;
            return default(T);
        }

        public T[] GetComponentsInChildren<T>(bool includeInactive)
        {
            var found = new List<T>();
            Collect(this, found);
            return found.ToArray();
        }

        static void Collect<T>(GameObject g, List<T> found)
        {
            foreach (Component c in g.components) if (c is T) found.Add((T)(object)c);
            foreach (Transform child in g.ownTransform.children)
                if (child.gameObject != null) Collect(child.gameObject, found);
        }

        public static GameObject CreatePrimitive(PrimitiveType type)
        {
            var g = new GameObject(type.ToString());
            g.AddComponent<MeshRenderer>();
            return g;
        }
    }

    public enum PrimitiveType { Sphere = 0, Capsule = 1, Cylinder = 2, Cube = 3, Plane = 4, Quad = 5 }

    public class Renderer : Component
    {
        Material[] materials = new Material[0];
        Rendering.LightProbeUsage probeUsage = Rendering.LightProbeUsage.BlendProbes;
        /// <summary>Stand-in only: the block last given to SetPropertyBlock (copied, as Unity copies it).</summary>
        public MaterialPropertyBlock StandInPropertyBlock;

        public Material sharedMaterial
        {
            get { return materials.Length == 0 ? null : materials[0]; }
            set { materials = new[] { value }; }
        }

        // Unity returns a copy of the array (GetSharedMaterialArray) and copies the one it is given.
        public Material[] sharedMaterials
        {
            get { return (Material[])materials.Clone(); }
            set { materials = value == null ? new Material[0] : (Material[])value.Clone(); }
        }

        public Rendering.LightProbeUsage lightProbeUsage { get { return probeUsage; } set { probeUsage = value; } }

        bool rendererEnabled = true;
        /// <summary>Stand-in only: what bounds returns (Unity computes it from the mesh and the transform).</summary>
        public Bounds StandInBounds;
        public bool enabled { get { return rendererEnabled; } set { rendererEnabled = value; } }
        /// <summary>The world-space axis-aligned box around the renderer.</summary>
        public Bounds bounds { get { return StandInBounds; } }

        public void SetPropertyBlock(MaterialPropertyBlock properties)
        {
            StandInPropertyBlock = properties == null ? null : properties.StandInCopy();
        }

        // Unity fills the block given with the renderer's (Renderer.GetPropertyBlock), clearing it first.
        public void GetPropertyBlock(MaterialPropertyBlock dest)
        {
            dest.Clear();
            if (StandInPropertyBlock != null) dest.StandInCopyFrom(StandInPropertyBlock);
        }
    }

    public class MeshRenderer : Renderer { }

    public sealed class MaterialPropertyBlock
    {
        readonly Dictionary<int, Color> colors = new Dictionary<int, Color>();
        Rendering.SphericalHarmonicsL2[] shArrays;
        public void SetColor(string name, Color value) { SetColor(Shader.PropertyToID(name), value); }
        public void SetColor(int nameID, Color value) { colors[nameID] = value; }
        public void Clear() { colors.Clear(); shArrays = null; }
        public bool isEmpty { get { return colors.Count == 0 && shArrays == null; } }

        // Unity packs each probe into unity_SHAr..unity_SHC for renderers with LightProbeUsage.CustomProvided
        // (UnityCsReference Runtime/Export/Shaders/MaterialPropertyBlock.cs); the stand-in keeps the probes.
        public void CopySHCoefficientArraysFrom(Rendering.SphericalHarmonicsL2[] lightProbes)
        {
            if (lightProbes == null) throw new ArgumentNullException("lightProbes");
            shArrays = (Rendering.SphericalHarmonicsL2[])lightProbes.Clone();
        }

        /// <summary>Stand-in only.</summary>
        public bool StandInTryGetColor(string name, out Color value) { return colors.TryGetValue(Shader.PropertyToID(name), out value); }
        /// <summary>Stand-in only: the probes last given to CopySHCoefficientArraysFrom; null if none.</summary>
        public Rendering.SphericalHarmonicsL2[] StandInSH { get { return shArrays; } }
        internal void StandInCopyFrom(MaterialPropertyBlock other)
        {
            foreach (KeyValuePair<int, Color> kv in other.colors) colors[kv.Key] = kv.Value;
            shArrays = other.shArrays;
        }
        internal MaterialPropertyBlock StandInCopy()
        {
            var copy = new MaterialPropertyBlock();
            foreach (KeyValuePair<int, Color> kv in colors) copy.colors[kv.Key] = kv.Value;
            copy.shArrays = shArrays == null ? null : (Rendering.SphericalHarmonicsL2[])shArrays.Clone();
            return copy;
        }
    }

    public class Material : Object
    {
        Shader materialShader;
        readonly Dictionary<int, float> floats = new Dictionary<int, float>();
        readonly Dictionary<int, Color> colors = new Dictionary<int, Color>();
        readonly HashSet<string> keywords = new HashSet<string>(StringComparer.Ordinal);

        public Material(Shader shader) { materialShader = shader; }

        public Material(Material source)
        {
            materialShader = source.materialShader;
            name = source.name;
            foreach (KeyValuePair<int, float> kv in source.floats) floats[kv.Key] = kv.Value;
            foreach (KeyValuePair<int, Color> kv in source.colors) colors[kv.Key] = kv.Value;
            keywords.UnionWith(source.keywords);
        }

        public Shader shader { get { return materialShader; } set { materialShader = value; } }
        public Color color { get { return GetColor("_Color"); } set { SetColor("_Color", value); } }

        public bool HasProperty(int nameID) { return materialShader != null && materialShader.StandInHasProperty(nameID); }
        public bool HasProperty(string name) { return HasProperty(Shader.PropertyToID(name)); }
        public void SetFloat(string name, float value) { SetFloat(Shader.PropertyToID(name), value); }
        public void SetFloat(int nameID, float value) { floats[nameID] = value; }
        public float GetFloat(string name) { return GetFloat(Shader.PropertyToID(name)); }
        public float GetFloat(int nameID) { float v; return floats.TryGetValue(nameID, out v) ? v : 0f; }
        public void SetColor(string name, Color value) { SetColor(Shader.PropertyToID(name), value); }
        public void SetColor(int nameID, Color value) { colors[nameID] = value; }
        public Color GetColor(string name) { return GetColor(Shader.PropertyToID(name)); }
        public Color GetColor(int nameID) { Color c; return colors.TryGetValue(nameID, out c) ? c : default(Color); }
        public void EnableKeyword(string keyword) { keywords.Add(keyword); }
        public void DisableKeyword(string keyword) { keywords.Remove(keyword); }
        public bool IsKeywordEnabled(string keyword) { return keywords.Contains(keyword); }
        public string[] shaderKeywords
        {
            get { var k = new string[keywords.Count]; keywords.CopyTo(k); return k; }
            set { keywords.Clear(); if (value != null) keywords.UnionWith(value); }
        }
    }

    public sealed class Shader : Object
    {
        static readonly Dictionary<string, int> ids = new Dictionary<string, int>(StringComparer.Ordinal);
        static readonly Dictionary<string, Shader> byName = new Dictionary<string, Shader>(StringComparer.Ordinal);
        /// <summary>Stand-in only: what SetGlobalMatrix received, by property id.</summary>
        public static readonly Dictionary<int, Matrix4x4> StandInGlobalMatrices = new Dictionary<int, Matrix4x4>();
        /// <summary>Stand-in only: what SetGlobalFloat received, by property id.</summary>
        public static readonly Dictionary<int, float> StandInGlobalFloats = new Dictionary<int, float>();
        readonly HashSet<int> properties = new HashSet<int>();

        Shader() { }

        /// <summary>Stand-in only: a shader of this name with these material properties (what an
        /// imported .shader file would be), found by Shader.Find afterwards.</summary>
        public static Shader StandInCreate(string name, params string[] propertyNames)
        {
            var s = new Shader();
            s.name = name;
            foreach (string p in propertyNames) s.properties.Add(PropertyToID(p));
            byName[name] = s;
            return s;
        }

        internal bool StandInHasProperty(int id) { return properties.Contains(id); }

        public static Shader Find(string name) { Shader s; return byName.TryGetValue(name, out s) ? s : null; }

        public static int PropertyToID(string name)
        {
            int id;
            if (!ids.TryGetValue(name, out id)) ids[name] = id = ids.Count + 1;
            return id;
        }

        public static void SetGlobalMatrix(int nameID, Matrix4x4 value) { StandInGlobalMatrices[nameID] = value; }
        public static void SetGlobalMatrix(string name, Matrix4x4 value) { SetGlobalMatrix(PropertyToID(name), value); }
        public static void SetGlobalFloat(int nameID, float value) { StandInGlobalFloats[nameID] = value; }
        public static void SetGlobalFloat(string name, float value) { SetGlobalFloat(PropertyToID(name), value); }
        /// <summary>Stand-in only: what SetGlobalInt and SetGlobalVectorArray received, by property id.</summary>
        public static readonly Dictionary<int, int> StandInGlobalInts = new Dictionary<int, int>();
        public static readonly Dictionary<int, Vector4[]> StandInGlobalVectorArrays = new Dictionary<int, Vector4[]>();
        public static void SetGlobalInt(int nameID, int value) { StandInGlobalInts[nameID] = value; }
        /// <summary>Stand-in only: what SetGlobalVector received, by property id.</summary>
        public static readonly Dictionary<int, Vector4> StandInGlobalVectors = new Dictionary<int, Vector4>();
        public static void SetGlobalVector(int nameID, Vector4 value) { StandInGlobalVectors[nameID] = value; }
        public static void SetGlobalVector(string name, Vector4 value) { SetGlobalVector(PropertyToID(name), value); }
        public static void SetGlobalVectorArray(int nameID, Vector4[] values)
        {
            // copied into the array held for this id (allocated once), as Unity copies into native memory
            Vector4[] held;
            if (!StandInGlobalVectorArrays.TryGetValue(nameID, out held) || held.Length != values.Length)
                StandInGlobalVectorArrays[nameID] = held = new Vector4[values.Length];
            System.Array.Copy(values, held, values.Length);
        }
        /// <summary>Stand-in only: what SetGlobalTexture received, and the global keywords on.</summary>
        public static readonly Dictionary<int, Texture> StandInGlobalTextures = new Dictionary<int, Texture>();
        static readonly HashSet<string> globalKeywords = new HashSet<string>(StringComparer.Ordinal);
        public static void SetGlobalTexture(int nameID, Texture value) { StandInGlobalTextures[nameID] = value; }
        public static void EnableKeyword(string keyword) { globalKeywords.Add(keyword); }
        public static void DisableKeyword(string keyword) { globalKeywords.Remove(keyword); }
        public static bool IsKeywordEnabled(string keyword) { return globalKeywords.Contains(keyword); }
    }

    public enum LightType { Spot = 0, Directional = 1, Point = 2, Area = 3, Rectangle = 3, Disc = 4 }

    public enum LightShadows { None = 0, Hard = 1, Soft = 2 }

    public sealed class Light : Behaviour
    {
        LightType lightType = LightType.Point;
        Color lightColor = Color.white;
        float lightIntensity = 1f;
        bool usesColorTemperature;
        LightShadows lightShadows = LightShadows.None;

        public LightType type { get { return lightType; } set { lightType = value; } }
        public Color color { get { return lightColor; } set { lightColor = value; } }
        public float intensity { get { return lightIntensity; } set { lightIntensity = value; } }
        public bool useColorTemperature { get { return usesColorTemperature; } set { usesColorTemperature = value; } }
        public LightShadows shadows { get { return lightShadows; } set { lightShadows = value; } }
        float lightShadowStrength = 1f;
        public float shadowStrength { get { return lightShadowStrength; } set { lightShadowStrength = value; } }
        float lightColorTemperature = 6570f;
        public float colorTemperature { get { return lightColorTemperature; } set { lightColorTemperature = value; } }
    }

    // Unity 2022.2's physical camera properties (what HDRP's Exposure "Physical Camera" mode reads).
    public sealed class Camera : Behaviour
    {
        float cameraAperture = 16f;
        int cameraIso = 200;
        float cameraShutterSpeed = 0.005f;
        public float aperture { get { return cameraAperture; } set { cameraAperture = value; } }
        public int iso { get { return cameraIso; } set { cameraIso = value; } }
        public float shutterSpeed { get { return cameraShutterSpeed; } set { cameraShutterSpeed = value; } }
    }

    public enum ColorSpace { Uninitialized = -1, Gamma = 0, Linear = 1 }

    public sealed class QualitySettings : Object
    {
        /// <summary>Stand-in only: what activeColorSpace reports (Unity: Player Settings → Color Space).</summary>
        public static ColorSpace StandInColorSpace = ColorSpace.Linear;
        public static ColorSpace activeColorSpace { get { return StandInColorSpace; } }
    }

    public sealed class RenderSettings : Object
    {
        static Rendering.AmbientMode mode = Rendering.AmbientMode.Trilight;
        static Rendering.SphericalHarmonicsL2 probe;
        static Light sunLight;

        public static Rendering.AmbientMode ambientMode { get { return mode; } set { mode = value; } }
        public static Rendering.SphericalHarmonicsL2 ambientProbe { get { return probe; } set { probe = value; } }
        public static Light sun { get { return sunLight; } set { sunLight = value; } }

        // Reflections. 2020.3 declares `Cubemap customReflection`; 2021 made it a Texture; 2022.1 added
        // `Texture customReflectionTexture` and made customReflection an obsolete Cubemap wrapper around it
        // (UnityCsReference, Runtime/Export/Graphics/GraphicsManagers.bindings.cs at 2020.3.0f1, 2021.3.0f1,
        // 2022.1.0a10). Both are here: the package is compiled with and without UNITY_2022_1_OR_NEWER.
        static Rendering.DefaultReflectionMode reflectionMode = Rendering.DefaultReflectionMode.Skybox;
        static Texture customTexture;
        static float reflectionIntensityValue = 1f;
        public static Rendering.DefaultReflectionMode defaultReflectionMode { get { return reflectionMode; } set { reflectionMode = value; } }
        public static Cubemap customReflection { get { return customTexture as Cubemap; } set { customTexture = value; } }
        public static Texture customReflectionTexture { get { return customTexture; } set { customTexture = value; } }
        public static float reflectionIntensity { get { return reflectionIntensityValue; } set { reflectionIntensityValue = value; } }
    }

    public enum FilterMode { Point = 0, Bilinear = 1, Trilinear = 2 }
    public enum TextureWrapMode { Repeat = 0, Clamp = 1, Mirror = 2, MirrorOnce = 3 }
    public enum TextureFormat { Alpha8 = 1, RGB24 = 3, RGBA32 = 4, ARGB32 = 5, RHalf = 15, RGHalf = 16, RGBAHalf = 17, RFloat = 18, RGBAFloat = 20 }
    public enum CubemapFace { Unknown = -1, PositiveX = 0, NegativeX = 1, PositiveY = 2, NegativeY = 3, PositiveZ = 4, NegativeZ = 5 }

    public class Texture : Object
    {
        FilterMode filter = FilterMode.Bilinear;
        TextureWrapMode wrap = TextureWrapMode.Repeat;
        public virtual int width { get { return 0; } set { throw new NotSupportedException(); } }
        public virtual int mipmapCount { get { return 1; } }
        public virtual bool isReadable { get { return true; } }
        public FilterMode filterMode { get { return filter; } set { filter = value; } }
        public TextureWrapMode wrapMode { get { return wrap; } set { wrap = value; } }
    }

    public sealed class Cubemap : Texture
    {
        readonly int size, mips;
        readonly TextureFormat textureFormat;
        readonly ushort[][] halves;   // [level * 6 + face]: RGBAHalf texels, 4 halves each (the only format modelled)
        bool readable = true;
        /// <summary>Stand-in only: Apply calls so far.</summary>
        public int StandInApplies;

        // Cubemap(int width, TextureFormat format, int mipCount): UnityCsReference 2020.3, Texture.cs
        public Cubemap(int width, TextureFormat format, int mipCount)
        {
            if (format != TextureFormat.RGBAHalf) throw new NotSupportedException("the stand-in models RGBAHalf cube maps only");
            int full = 0;
            for (int n = width; n >= 1; n >>= 1) full++;
            if (width <= 0 || mipCount < 1 || mipCount > full) throw new UnityException("Failed to create texture because of invalid parameters.");
            size = width; mips = mipCount; textureFormat = format;
            halves = new ushort[mips * 6][];
            for (int m = 0; m < mips; m++)
                for (int f = 0; f < 6; f++)
                {
                    int n = Math.Max(1, width >> m);
                    halves[m * 6 + f] = new ushort[4 * n * n];
                }
        }

        public override int width { get { return size; } set { throw new NotSupportedException(); } }
        public int height { get { return size; } }
        public override int mipmapCount { get { return mips; } }
        public override bool isReadable { get { return readable; } }
        public TextureFormat format { get { return textureFormat; } }

        // Unity's GetPixelData returns a view of the texture's CPU copy (no managed allocation).
        public Unity.Collections.NativeArray<T> GetPixelData<T>(int mipLevel, CubemapFace face) where T : struct
        {
            if (!readable) throw new UnityException("Texture is not readable");
            if (mipLevel < 0 || mipLevel >= mips || face < CubemapFace.PositiveX || face > CubemapFace.NegativeZ)
                throw new ArgumentException("invalid mip level or face");
            var data = halves[mipLevel * 6 + (int)face] as T[];
            if (data == null) throw new ArgumentException("the stand-in's RGBAHalf data is read as ushort");
            return new Unity.Collections.NativeArray<T>(data);
        }

        // As in UnityCsReference 2020.3 (Texture.cs:840-847): Marshal.SizeOf(data[0]) boxes an element, so
        // this overload allocates on every call (the package uses GetPixelData instead).
        public void SetPixelData<T>(T[] data, int mipLevel, CubemapFace face, int sourceDataStartIndex = 0)
        {
            if (data == null || data.Length == 0) throw new UnityException("No texture data provided to SetPixelData.");
            int elementSize = System.Runtime.InteropServices.Marshal.SizeOf(data[0]);
            var dst = halves[mipLevel * 6 + (int)face];
            if (elementSize != 2 || data.Length - sourceDataStartIndex < dst.Length) throw new UnityException("SetPixelData: wrong size");
            Array.Copy(data, sourceDataStartIndex, dst, 0, dst.Length);
        }

        public void Apply(bool updateMipmaps, bool makeNoLongerReadable)
        {
            if (!readable) throw new UnityException("Texture is not readable");
            StandInApplies++;
            if (makeNoLongerReadable) readable = false;
        }

        /// <summary>Stand-in only: the texels of a level and face (RGBA halves, rows top first).</summary>
        public ushort[] StandInTexels(int mipLevel, CubemapFace face) { return halves[mipLevel * 6 + (int)face]; }
    }

    public class UnityException : Exception { public UnityException(string message) : base(message) { } }

    public sealed class ReflectionProbe : Behaviour
    {
        Rendering.ReflectionProbeMode probeMode = Rendering.ReflectionProbeMode.Baked;
        Texture customTexture;
        public Rendering.ReflectionProbeMode mode { get { return probeMode; } set { probeMode = value; } }
        public Texture customBakedTexture { get { return customTexture; } set { customTexture = value; } }
    }

    public enum TextAnchor
    {
        UpperLeft = 0, UpperCenter = 1, UpperRight = 2, MiddleLeft = 3, MiddleCenter = 4, MiddleRight = 5,
        LowerLeft = 6, LowerCenter = 7, LowerRight = 8
    }

    public sealed class TextMesh : Component
    {
        string content = "";
        float size = 1f;
        int font;
        TextAnchor textAnchor;
        Color textColor = Color.white;

        public string text { get { return content; } set { content = value; } }
        public float characterSize { get { return size; } set { size = value; } }
        public int fontSize { get { return font; } set { font = value; } }
        public TextAnchor anchor { get { return textAnchor; } set { textAnchor = value; } }
        public Color color { get { return textColor; } set { textColor = value; } }
    }

    public struct Bounds
    {
        Vector3 boxCenter, boxExtents;
        public Bounds(Vector3 center, Vector3 size) { boxCenter = center; boxExtents = size * 0.5f; }
        public Vector3 center { get { return boxCenter; } set { boxCenter = value; } }
        public Vector3 extents { get { return boxExtents; } set { boxExtents = value; } }
        public Vector3 size { get { return boxExtents * 2f; } set { boxExtents = value * 0.5f; } }
        public Vector3 min { get { return boxCenter - boxExtents; } }
        public Vector3 max { get { return boxCenter + boxExtents; } }
    }

    public struct Vector4
    {
        public float x, y, z, w;
        public Vector4(float x, float y, float z, float w) { this.x = x; this.y = y; this.z = z; this.w = w; }
    }

    public struct Vector3
    {
        public float x, y, z;
        public Vector3(float x, float y, float z) { this.x = x; this.y = y; this.z = z; }
        public static Vector3 zero { get { return new Vector3(0, 0, 0); } }
        public static Vector3 one { get { return new Vector3(1, 1, 1); } }
        public static Vector3 up { get { return new Vector3(0, 1, 0); } }
        public static Vector3 right { get { return new Vector3(1, 0, 0); } }
        public static Vector3 forward { get { return new Vector3(0, 0, 1); } }
        public static Vector3 operator *(Vector3 a, float d) { return new Vector3(a.x * d, a.y * d, a.z * d); }
        public static Vector3 operator *(float d, Vector3 a) { return new Vector3(a.x * d, a.y * d, a.z * d); }
        public static Vector3 operator +(Vector3 a, Vector3 b) { return new Vector3(a.x + b.x, a.y + b.y, a.z + b.z); }
        public static Vector3 operator -(Vector3 a, Vector3 b) { return new Vector3(a.x - b.x, a.y - b.y, a.z - b.z); }
        public static Vector3 operator -(Vector3 a) { return new Vector3(-a.x, -a.y, -a.z); }
    }

    public struct Quaternion
    {
        public float x, y, z, w;
        public Quaternion(float x, float y, float z, float w) { this.x = x; this.y = y; this.z = z; this.w = w; }
        public static Quaternion identity { get { return new Quaternion(0, 0, 0, 1); } }

        // The rotation of a vector by a unit quaternion (v' = q v q*), written out.
        public static Vector3 operator *(Quaternion q, Vector3 v)
        {
            float tx = 2f * (q.y * v.z - q.z * v.y), ty = 2f * (q.z * v.x - q.x * v.z), tz = 2f * (q.x * v.y - q.y * v.x);
            return new Vector3(v.x + q.w * tx + (q.y * tz - q.z * ty),
                               v.y + q.w * ty + (q.z * tx - q.x * tz),
                               v.z + q.w * tz + (q.x * ty - q.y * tx));
        }

        // Unity's == compares with a tolerance (dot > 1 - kEpsilon); the package compares exactly itself.
        public static bool operator ==(Quaternion a, Quaternion b)
        {
            return a.x * b.x + a.y * b.y + a.z * b.z + a.w * b.w > 1.0f - 0.000001f;
        }
        public static bool operator !=(Quaternion a, Quaternion b) { return !(a == b); }
        public override bool Equals(object o)
        {
            if (!(o is Quaternion)) return false;
            var q = (Quaternion)o;
            return x.Equals(q.x) && y.Equals(q.y) && z.Equals(q.z) && w.Equals(q.w);
        }
        public override int GetHashCode() { return x.GetHashCode() ^ (y.GetHashCode() << 2) ^ (z.GetHashCode() >> 2) ^ (w.GetHashCode() >> 1); }
    }

    public struct Color
    {
        public float r, g, b, a;
        public Color(float r, float g, float b, float a) { this.r = r; this.g = g; this.b = b; this.a = a; }
        public Color(float r, float g, float b) : this(r, g, b, 1f) { }
        public static Color white { get { return new Color(1, 1, 1, 1); } }
        public static Color black { get { return new Color(0, 0, 0, 1); } }
        public Color linear { get { return new Color(Mathf.GammaToLinearSpace(r), Mathf.GammaToLinearSpace(g), Mathf.GammaToLinearSpace(b), a); } }
        public Color gamma { get { return new Color(Mathf.LinearToGammaSpace(r), Mathf.LinearToGammaSpace(g), Mathf.LinearToGammaSpace(b), a); } }
        public static Color operator *(Color c, float d) { return new Color(c.r * d, c.g * d, c.b * d, c.a * d); }
    }

    public struct Matrix4x4
    {
        // Unity's fields, named m<row><column>; the one-index indexer is column-major.
        public float m00, m10, m20, m30, m01, m11, m21, m31, m02, m12, m22, m32, m03, m13, m23, m33;

        public float this[int row, int column]
        {
            get { return this[row + column * 4]; }
            set { this[row + column * 4] = value; }
        }

        public float this[int index]
        {
            get
            {
                switch (index)
                {
                    case 0: return m00; case 1: return m10; case 2: return m20; case 3: return m30;
                    case 4: return m01; case 5: return m11; case 6: return m21; case 7: return m31;
                    case 8: return m02; case 9: return m12; case 10: return m22; case 11: return m32;
                    case 12: return m03; case 13: return m13; case 14: return m23; case 15: return m33;
                    default: throw new IndexOutOfRangeException("Invalid matrix index!");
                }
            }
            set
            {
                switch (index)
                {
                    case 0: m00 = value; break; case 1: m10 = value; break; case 2: m20 = value; break; case 3: m30 = value; break;
                    case 4: m01 = value; break; case 5: m11 = value; break; case 6: m21 = value; break; case 7: m31 = value; break;
                    case 8: m02 = value; break; case 9: m12 = value; break; case 10: m22 = value; break; case 11: m32 = value; break;
                    case 12: m03 = value; break; case 13: m13 = value; break; case 14: m23 = value; break; case 15: m33 = value; break;
                    default: throw new IndexOutOfRangeException("Invalid matrix index!");
                }
            }
        }
    }

    public struct Mathf
    {
        public static float Max(float a, float b) { return a > b ? a : b; }
        public static float Min(float a, float b) { return a < b ? a : b; }
        public static float Clamp(float value, float min, float max) { return value < min ? min : value > max ? max : value; }
        // Stand-in only (Unity's own fit is native): a blackbody's linear Rec. 709 colour, brightest channel 1,
        // from Krystek's (1985) CIE 1960 uv of the Planckian locus; what matters to the package is that it is
        // linear RGB of the temperature's chromaticity.
        public static Color CorrelatedColorTemperatureToRGB(float kelvin)
        {
            double t = Math.Max(1000.0, Math.Min(40000.0, kelvin));
            double u = (0.860117757 + 1.54118254e-4 * t + 1.28641212e-7 * t * t) / (1 + 8.42420235e-4 * t + 7.08145163e-7 * t * t);
            double v = (0.317398726 + 4.22806245e-5 * t + 4.20481691e-8 * t * t) / (1 - 2.89741816e-5 * t + 1.61456053e-7 * t * t);
            double x = 3 * u / (2 * u - 8 * v + 4), y = 2 * v / (2 * u - 8 * v + 4);
            double X = x / y, Z = (1 - x - y) / y;
            double r = 3.2404542 * X - 1.5371385 - 0.4985314 * Z;
            double g = -0.9692660 * X + 1.8760108 + 0.0415560 * Z;
            double b = 0.0556434 * X - 0.2040259 + 1.0572252 * Z;
            r = Math.Max(0, r); g = Math.Max(0, g); b = Math.Max(0, b);
            double m = Math.Max(r, Math.Max(g, b));
            return new Color((float)(r / m), (float)(g / m), (float)(b / m), 1f);
        }
        // The curves of UnityCG.cginc's GammaToLinearSpaceExact / LinearToGammaSpaceExact.
        public static float GammaToLinearSpace(float value)
        {
            if (value <= 0.04045f) return value / 12.92f;
            if (value < 1.0f) return (float)Math.Pow((value + 0.055) / 1.055, 2.4);
            return (float)Math.Pow(value, 2.2);
        }
        public static float LinearToGammaSpace(float value)
        {
            if (value <= 0.0f) return 0.0f;
            if (value <= 0.0031308f) return 12.92f * value;
            if (value < 1.0f) return 1.055f * (float)Math.Pow(value, 0.4166667) - 0.055f;
            return (float)Math.Pow(value, 0.45454545);
        }
    }

    // ---- light probes at runtime (Unity 6: UnityCsReference Runtime/Export/Graphics/LightProbes.bindings.cs) ----
    // Stand-in only: holds what is set; Tetrahedralize counts its calls; GetInterpolatedProbe answers at a probe's
    // own position (Unity blends the tetrahedron's four; at a vertex that is the vertex's probe) and nowhere else.
    public sealed class LightProbes : Object
    {
        Vector3[] positionsSelf = new Vector3[0];
        Rendering.SphericalHarmonicsL2[] probes = new Rendering.SphericalHarmonicsL2[0];
        public static int StandInTetrahedralizeCalls;
        internal LightProbes() { }
        public static LightProbes StandInCreate() { return new LightProbes(); }

        public Vector3[] positions { get { return (Vector3[])positionsSelf.Clone(); } }
        public int count { get { return positionsSelf.Length; } }
        public Vector3[] GetPositionsSelf() { return (Vector3[])positionsSelf.Clone(); }
        public bool SetPositionsSelf(Vector3[] positions, bool checkForDuplicatePositions)
        {
            if (positions == null) return false;
            positionsSelf = (Vector3[])positions.Clone();
            return true;
        }
        // Unity refuses an array of another size than the probes' count ("must match").
        public Rendering.SphericalHarmonicsL2[] bakedProbes
        {
            get { return (Rendering.SphericalHarmonicsL2[])probes.Clone(); }
            set
            {
                if (value == null || value.Length != positionsSelf.Length)
                    throw new ArgumentException("bakedProbes: the array size must match the light probes' count");
                probes = (Rendering.SphericalHarmonicsL2[])value.Clone();
            }
        }
        public static void Tetrahedralize() { StandInTetrahedralizeCalls++; }

        public static void GetInterpolatedProbe(Vector3 position, Renderer renderer, out Rendering.SphericalHarmonicsL2 probe)
        {
            LightProbes lp = LightmapSettings.lightProbes;
            if (lp != null)
                for (int i = 0; i < lp.positionsSelf.Length; i++)
                {
                    Vector3 p = lp.positionsSelf[i];
                    if (Math.Abs(p.x - position.x) < 1e-5f && Math.Abs(p.y - position.y) < 1e-5f && Math.Abs(p.z - position.z) < 1e-5f)
                    {
                        probe = lp.probes[i];
                        return;
                    }
                }
            throw new NotSupportedException("stand-in: GetInterpolatedProbe only at a probe's position");
        }
    }

    public sealed class LightmapSettings : Object
    {
        static LightProbes current;
        public static LightProbes lightProbes { get { return current; } set { current = value; } }
    }

    public sealed class Time
    {
        public static float unscaledTime { get { return (float)(DateTime.UtcNow - DateTime.Today).TotalSeconds; } }
        /// <summary>Stand-in only: the harness advances it once per frame it plays.</summary>
        public static int StandInFrameCount;
        public static int frameCount { get { return StandInFrameCount; } }
    }

    // ---- textures the passthrough sender and the display lookup use -------------------------------------------
    // Stand-in only: a texture's pixels are not modelled; it carries StandInBytes, the bytes of an image already
    // encoded as JPEG, which Graphics.Blit and ReadPixels pass along and ImageConversion.EncodeToJPG returns.

    public struct Vector2
    {
        public float x, y;
        public Vector2(float x, float y) { this.x = x; this.y = y; }
    }

    public struct Vector2Int
    {
        int vx, vy;
        public Vector2Int(int x, int y) { vx = x; vy = y; }
        public int x { get { return vx; } set { vx = value; } }
        public int y { get { return vy; } set { vy = value; } }
    }

    public struct Rect
    {
        public float x, y, width, height;
        public Rect(float x, float y, float width, float height) { this.x = x; this.y = y; this.width = width; this.height = height; }
    }

    public struct Pose
    {
        public Vector3 position;
        public Quaternion rotation;
        public Pose(Vector3 position, Quaternion rotation) { this.position = position; this.rotation = rotation; }
    }

    public sealed class Texture2D : Texture
    {
        readonly int w, h;
        public byte[] StandInBytes;
        public readonly Color[] StandInPixels;
        public Texture2D(int width, int height, TextureFormat textureFormat, bool mipChain, bool linear)
        {
            w = width; h = height;
            StandInPixels = new Color[width * height];
        }
        public Texture2D(int width, int height, TextureFormat textureFormat, bool mipChain) : this(width, height, textureFormat, mipChain, false) { }
        public override int width { get { return w; } set { throw new NotSupportedException(); } }
        public int height { get { return h; } }
        public void SetPixels(Color[] colors)
        {
            if (colors.Length != StandInPixels.Length) throw new UnityException("SetPixels: wrong size");
            Array.Copy(colors, StandInPixels, colors.Length);
        }
        public void Apply(bool updateMipmaps) { }
        public void Apply() { }
        public void ReadPixels(Rect source, int destX, int destY)
        {
            RenderTexture rt = RenderTexture.active;
            if (rt == null) throw new UnityException("ReadPixels: no active RenderTexture");
            StandInBytes = rt.StandInBytes;
        }
    }

    public enum RenderTextureFormat { ARGB32 = 0, Default = 7 }
    public enum RenderTextureReadWrite { Default = 0, Linear = 1, sRGB = 2 }

    public sealed class RenderTexture : Texture
    {
        readonly int w, h;
        public byte[] StandInBytes;
        public RenderTexture(int width, int height, int depth, RenderTextureFormat format, RenderTextureReadWrite readWrite) { w = width; h = height; }
        public override int width { get { return w; } set { throw new NotSupportedException(); } }
        public int height { get { return h; } }
        public bool Create() { return true; }
        public void Release() { }
        public static RenderTexture active { get; set; }
    }

    public sealed class Graphics
    {
        public static void Blit(Texture source, RenderTexture dest)
        {
            var t2 = source as Texture2D;
            var rt = source as RenderTexture;
            dest.StandInBytes = t2 != null ? t2.StandInBytes : rt != null ? rt.StandInBytes : null;
        }
    }

    public static class ImageConversion
    {
        public static byte[] EncodeToJPG(Texture2D tex, int quality) { return tex.StandInBytes; }
    }

    public sealed class Debug
    {
        /// <summary>Stand-in only: messages logged so far (a harness tells event frames from steady ones).</summary>
        public static int StandInMessages;
        // stderr: a program built with the stand-in keeps stdout for its own output
        public static void Log(object message) { StandInMessages++; Console.Error.WriteLine(message); }
        public static void Log(object message, Object context) { StandInMessages++; Console.Error.WriteLine(message); }
        public static void LogWarning(object message) { StandInMessages++; Console.Error.WriteLine("warning: " + message); }
        public static void LogWarning(object message, Object context) { StandInMessages++; Console.Error.WriteLine("warning: " + message); }
        public static void LogError(object message) { StandInMessages++; Console.Error.WriteLine("error: " + message); }
        public static void LogError(object message, Object context) { StandInMessages++; Console.Error.WriteLine("error: " + message); }
    }

    public abstract class PropertyAttribute : Attribute { }

    [AttributeUsage(AttributeTargets.Field)] public sealed class SerializeField : Attribute { }
    [AttributeUsage(AttributeTargets.Field, Inherited = true, AllowMultiple = true)]
    public class HeaderAttribute : PropertyAttribute { public readonly string header; public HeaderAttribute(string header) { this.header = header; } }
    [AttributeUsage(AttributeTargets.Field, Inherited = true, AllowMultiple = false)]
    public class TooltipAttribute : PropertyAttribute { public readonly string tooltip; public TooltipAttribute(string tooltip) { this.tooltip = tooltip; } }
    [AttributeUsage(AttributeTargets.Field, Inherited = true, AllowMultiple = false)]
    public sealed class RangeAttribute : PropertyAttribute { public readonly float min, max; public RangeAttribute(float min, float max) { this.min = min; this.max = max; } }
    [AttributeUsage(AttributeTargets.Field, Inherited = true, AllowMultiple = false)]
    public sealed class MinAttribute : PropertyAttribute { public readonly float min; public MinAttribute(float min) { this.min = min; } }
    [AttributeUsage(AttributeTargets.Class, AllowMultiple = false)]
    public sealed class AddComponentMenu : Attribute { public AddComponentMenu(string menuName) { } }
    [AttributeUsage(AttributeTargets.Class, Inherited = false)]
    public sealed class DisallowMultipleComponent : Attribute { }
    [AttributeUsage(AttributeTargets.Class, AllowMultiple = true)]
    public sealed class RequireComponent : Attribute { public RequireComponent(Type requiredComponent) { } }
    [AttributeUsage(AttributeTargets.Class)]
    public class DefaultExecutionOrder : Attribute { public DefaultExecutionOrder(int order) { } }
    [AttributeUsage(AttributeTargets.Class, AllowMultiple = false)]
    public sealed class HelpURLAttribute : Attribute { public HelpURLAttribute(string url) { } }
}

namespace UnityEngine.Rendering
{
    public enum AmbientMode { Skybox = 0, Trilight = 1, Flat = 3, Custom = 4 }

    public enum DefaultReflectionMode { Skybox = 0, Custom = 1 }

    public enum ReflectionProbeMode { Baked = 0, Realtime = 1, Custom = 2 }

    public enum LightProbeUsage { Off = 0, BlendProbes = 1, UseProxyVolume = 2, CustomProvided = 4 }

    public sealed class GraphicsSettings : Object
    {
        static bool linearIntensity;
        public static bool lightsUseLinearIntensity { get { return linearIntensity; } set { linearIntensity = value; } }
        static bool colorTemperature;
        public static bool lightsUseColorTemperature { get { return colorTemperature; } set { colorTemperature = value; } }
    }

    public struct SphericalHarmonicsL2
    {
        // Unity's 27 private floats: shr0..shr8, shg0..shg8, shb0..shb8; indexer [rgb, coefficient].
        float shr0, shr1, shr2, shr3, shr4, shr5, shr6, shr7, shr8;
        float shg0, shg1, shg2, shg3, shg4, shg5, shg6, shg7, shg8;
        float shb0, shb1, shb2, shb3, shb4, shb5, shb6, shb7, shb8;

        public void Clear() { this = default(SphericalHarmonicsL2); }

        public float this[int rgb, int coefficient]
        {
            get
            {
                switch (Index(rgb, coefficient))
                {
                    case 0: return shr0; case 1: return shr1; case 2: return shr2; case 3: return shr3; case 4: return shr4;
                    case 5: return shr5; case 6: return shr6; case 7: return shr7; case 8: return shr8;
                    case 9: return shg0; case 10: return shg1; case 11: return shg2; case 12: return shg3; case 13: return shg4;
                    case 14: return shg5; case 15: return shg6; case 16: return shg7; case 17: return shg8;
                    case 18: return shb0; case 19: return shb1; case 20: return shb2; case 21: return shb3; case 22: return shb4;
                    case 23: return shb5; case 24: return shb6; case 25: return shb7; default: return shb8;
                }
            }
            set
            {
                switch (Index(rgb, coefficient))
                {
                    case 0: shr0 = value; break; case 1: shr1 = value; break; case 2: shr2 = value; break;
                    case 3: shr3 = value; break; case 4: shr4 = value; break; case 5: shr5 = value; break;
                    case 6: shr6 = value; break; case 7: shr7 = value; break; case 8: shr8 = value; break;
                    case 9: shg0 = value; break; case 10: shg1 = value; break; case 11: shg2 = value; break;
                    case 12: shg3 = value; break; case 13: shg4 = value; break; case 14: shg5 = value; break;
                    case 15: shg6 = value; break; case 16: shg7 = value; break; case 17: shg8 = value; break;
                    case 18: shb0 = value; break; case 19: shb1 = value; break; case 20: shb2 = value; break;
                    case 21: shb3 = value; break; case 22: shb4 = value; break; case 23: shb5 = value; break;
                    case 24: shb6 = value; break; case 25: shb7 = value; break; default: shb8 = value; break;
                }
            }
        }

        // Stand-in maths: what Unity's shaders make of these values (UnityCG.cginc's ShadeSH9 on the
        // constants packed from them: basis 1, y, z, x, xy, yz, 3z²-1, xz, x²-y², Sh9Math.ShadeSH9), for the
        // values the ambient probe and light probes hold. Unity's native Evaluate is not published.
        public void Evaluate(Vector3[] directions, Color[] results)
        {
            if (directions == null || results == null || directions.Length != results.Length)
                throw new ArgumentException("directions and results must have the same size");
            for (int d = 0; d < directions.Length; d++)
            {
                float x = directions[d].x, y = directions[d].y, z = directions[d].z;
                float[] basis = { 1f, y, z, x, x * y, y * z, 3f * z * z - 1f, x * z, x * x - y * y };
                var rgb = new float[3];
                for (int c = 0; c < 3; c++)
                    for (int i = 0; i < 9; i++) rgb[c] += this[c, i] * basis[i];
                results[d] = new Color(rgb[0], rgb[1], rgb[2], 1f);
            }
        }

        static int Index(int rgb, int coefficient)
        {
            if (rgb < 0 || rgb > 2 || coefficient < 0 || coefficient > 8)
                throw new IndexOutOfRangeException("Invalid index!");
            return rgb * 9 + coefficient;
        }
    }
}

namespace Unity.Collections
{
    // A view of native memory in Unity; here a view of a managed array (what Cubemap.GetPixelData hands out).
    public struct NativeArray<T> where T : struct
    {
        readonly T[] buffer;
        internal NativeArray(T[] buffer) { this.buffer = buffer; }
        public int Length { get { return buffer == null ? 0 : buffer.Length; } }
        public bool IsCreated { get { return buffer != null; } }
        public T this[int index] { get { return buffer[index]; } set { buffer[index] = value; } }

        // NativeArray<T>.Copy(T[] src, int srcIndex, NativeArray<T> dst, int dstIndex, int length):
        // UnityCsReference 2020.3, Runtime/Export/NativeArray/NativeArray.cs:462 (pins src, MemCpy).
        public static void Copy(T[] src, int srcIndex, NativeArray<T> dst, int dstIndex, int length)
        {
            if (src == null) throw new ArgumentNullException("src");
            if (length < 0 || srcIndex < 0 || srcIndex + length > src.Length || dstIndex < 0 || dstIndex + length > dst.Length)
                throw new ArgumentOutOfRangeException("length", "copy out of range");
            Array.Copy(src, srcIndex, dst.buffer, dstIndex, length);
        }
    }
}

namespace UnityEngine
{
    public class AsyncOperation { internal volatile bool done; public bool isDone { get { return done; } } }
}

namespace UnityEngine.Networking
{
    // UnityWebRequest (UnityCsReference Modules/UnityWebRequest/Public/UnityWebRequest.bindings.cs), the members the
    // package uses. Stand-in only: a real HTTP GET on a thread pool thread (HttpWebRequest); isDone turns true
    // when the answer is in, as Unity's does between frames.
    public sealed class UnityWebRequestAsyncOperation : AsyncOperation { }

    public sealed class DownloadHandler { internal string body = ""; public string text { get { return body; } } }

    public sealed class UnityWebRequest : IDisposable
    {
        public enum Result { InProgress, Success, ConnectionError, ProtocolError, DataProcessingError }
        readonly string address;
        readonly System.Collections.Generic.Dictionary<string, string> headers = new System.Collections.Generic.Dictionary<string, string>();
        volatile Result outcome = Result.InProgress;
        string failure;
        long code;
        public int timeout;
        public readonly DownloadHandler downloadHandler = new DownloadHandler();
        UnityWebRequest(string url) { address = url; }

        public static UnityWebRequest Get(string uri) { return new UnityWebRequest(uri); }
        public string url { get { return address; } }
        public Result result { get { return outcome; } }
        public string error { get { return failure; } }
        public long responseCode { get { return code; } }
        public bool isDone { get { return outcome != Result.InProgress; } }
        public void SetRequestHeader(string name, string value) { headers[name] = value; }

        public UnityWebRequestAsyncOperation SendWebRequest()
        {
            var op = new UnityWebRequestAsyncOperation();
            System.Threading.ThreadPool.QueueUserWorkItem(_ =>
            {
                try
                {
                    var rq = (System.Net.HttpWebRequest)System.Net.WebRequest.Create(address);
                    foreach (var h in headers) rq.Headers[h.Key] = h.Value;
                    if (timeout > 0) rq.Timeout = timeout * 1000;
                    System.Net.HttpWebResponse rs;
                    try { rs = (System.Net.HttpWebResponse)rq.GetResponse(); }
                    catch (System.Net.WebException e)
                    {
                        rs = e.Response as System.Net.HttpWebResponse;
                        if (rs == null) { failure = e.Message; outcome = Result.ConnectionError; return; }
                    }
                    using (rs)
                    using (var reader = new System.IO.StreamReader(rs.GetResponseStream()))
                    {
                        downloadHandler.body = reader.ReadToEnd();
                        code = (long)rs.StatusCode;
                    }
                    if (code >= 400) failure = "HTTP/1.1 " + code;
                    outcome = code >= 400 ? Result.ProtocolError : Result.Success;
                }
                catch (Exception e) { failure = e.Message; outcome = Result.ConnectionError; }
                finally { op.done = true; }
            });
            return op;
        }

        public void Dispose() { }
    }
}
