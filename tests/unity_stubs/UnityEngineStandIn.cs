// COMPILE-ONLY STAND-IN FOR UnityEngine -- NOT UNITY.
//
// The smallest set of UnityEngine types that the package's MonoBehaviours and sample scripts
// use, so that Mono's mcs can type-check them on a machine without Unity. Signatures follow the
// Unity scripting API (2020.3); behaviour is a trivial model at best: Shader.SetGlobalMatrix and
// RenderSettings just store what they are given so a test can read it back. Nothing that runs
// against this file has run in Unity, and no test claims so.
using System;
using System.Collections.Generic;

namespace UnityEngine
{
    public class Object
    {
        public string name = "";
        public static T FindObjectOfType<T>() where T : Object { return null; }
        public static void Destroy(Object obj) { }
    }

    public class Component : Object
    {
        Transform t;
        public Transform transform { get { return t ?? (t = this as Transform ?? new Transform()); } }
        public GameObject gameObject { get { return null; } }
        public T GetComponent<T>() where T : Component { return null; }
    }

    public class Behaviour : Component
    {
        public bool enabled = true;
        public bool isActiveAndEnabled { get { return enabled; } }
    }

    public class MonoBehaviour : Behaviour { }

    public class Transform : Component
    {
        public Quaternion rotation = Quaternion.identity;
        public Vector3 position;
        public Vector3 localPosition;
        public Vector3 localScale = new Vector3(1, 1, 1);
        public void SetParent(Transform parent, bool worldPositionStays) { }
    }

    public sealed class GameObject : Object
    {
        public GameObject(string name) { this.name = name; }
        public Transform transform { get { return new Transform(); } }
        public T AddComponent<T>() where T : Component, new() { return new T(); }
        public T GetComponent<T>() where T : Component { return null; }
        public static GameObject CreatePrimitive(PrimitiveType type) { return new GameObject(type.ToString()); }
    }

    public enum PrimitiveType { Sphere = 0, Capsule = 1, Cylinder = 2, Cube = 3, Plane = 4, Quad = 5 }

    public class Renderer : Component
    {
        public Material sharedMaterial;
    }

    public class Material : Object
    {
        public Material(Shader shader) { }
        public Material(Material source) { }
        public Color color;
        public void SetColor(string property, Color value) { }
    }

    public enum TextAnchor { UpperLeft = 0, UpperCenter = 1, MiddleCenter = 4, LowerCenter = 7 }

    public sealed class TextMesh : Component
    {
        public string text;
        public float characterSize = 1;
        public int fontSize;
        public TextAnchor anchor;
        public Color color;
    }

    public struct Vector3
    {
        public float x, y, z;
        public Vector3(float x, float y, float z) { this.x = x; this.y = y; this.z = z; }
        public static Vector3 up { get { return new Vector3(0, 1, 0); } }
        public static Vector3 right { get { return new Vector3(1, 0, 0); } }
        public static Vector3 forward { get { return new Vector3(0, 0, 1); } }
        public static Vector3 operator *(Vector3 a, float d) { return new Vector3(a.x * d, a.y * d, a.z * d); }
        public static Vector3 operator +(Vector3 a, Vector3 b) { return new Vector3(a.x + b.x, a.y + b.y, a.z + b.z); }
    }

    public struct Quaternion
    {
        public float x, y, z, w;
        public Quaternion(float x, float y, float z, float w) { this.x = x; this.y = y; this.z = z; this.w = w; }
        public static Quaternion identity { get { return new Quaternion(0, 0, 0, 1); } }
        public static bool operator ==(Quaternion a, Quaternion b) { return a.x == b.x && a.y == b.y && a.z == b.z && a.w == b.w; }
        public static bool operator !=(Quaternion a, Quaternion b) { return !(a == b); }
        public override bool Equals(object o) { return o is Quaternion && this == (Quaternion)o; }
        public override int GetHashCode() { return x.GetHashCode() ^ y.GetHashCode() ^ z.GetHashCode() ^ w.GetHashCode(); }
    }

    public struct Color
    {
        public float r, g, b, a;
        public Color(float r, float g, float b, float a) { this.r = r; this.g = g; this.b = b; this.a = a; }
        public Color(float r, float g, float b) : this(r, g, b, 1f) { }
        public static Color white { get { return new Color(1, 1, 1, 1); } }
        /// <summary>sRGB → linear per channel, as Unity's Color.linear.</summary>
        public Color linear { get { return new Color(Mathf.GammaToLinearSpace(r), Mathf.GammaToLinearSpace(g), Mathf.GammaToLinearSpace(b), a); } }
    }

    public struct Matrix4x4
    {
        // Row-major; the real type has fields m00..m33 and the same [row, column] indexer.
        // Copy-on-write keeps value semantics (a copy never sees later writes).
        float[] m;
        public float this[int row, int column]
        {
            get { return m == null ? 0f : m[4 * row + column]; }
            set { m = m == null ? new float[16] : (float[])m.Clone(); m[4 * row + column] = value; }
        }
    }

    public sealed class Shader : Object
    {
        static readonly Dictionary<string, int> ids = new Dictionary<string, int>();
        /// <summary>Stand-in only: what SetGlobalMatrix received, by property id.</summary>
        public static readonly Dictionary<int, Matrix4x4> StandInGlobalMatrices = new Dictionary<int, Matrix4x4>();
        public static int PropertyToID(string name)
        {
            int id;
            if (!ids.TryGetValue(name, out id)) ids[name] = id = ids.Count + 1;
            return id;
        }
        public static void SetGlobalMatrix(int nameID, Matrix4x4 value) { StandInGlobalMatrices[nameID] = value; }
        public static void SetGlobalMatrix(string name, Matrix4x4 value) { SetGlobalMatrix(PropertyToID(name), value); }
        public static Shader Find(string name) { return null; }
    }

    public static class RenderSettings
    {
        public static Rendering.AmbientMode ambientMode = Rendering.AmbientMode.Trilight;
        public static Rendering.SphericalHarmonicsL2 ambientProbe;
    }

    public static class Mathf
    {
        public static float Max(float a, float b) { return a > b ? a : b; }
        public static float Min(float a, float b) { return a < b ? a : b; }
        public static float GammaToLinearSpace(float v)
        {
            return v <= 0.04045f ? v / 12.92f : (float)Math.Pow((v + 0.055) / 1.055, 2.4);
        }
    }

    public static class Time
    {
        public static float unscaledTime { get { return (float)(DateTime.UtcNow - DateTime.Today).TotalSeconds; } }
    }

    public static class Debug
    {
        // stderr: a program built with the stand-in keeps stdout for its own output
        public static void Log(object message) { Console.Error.WriteLine(message); }
        public static void Log(object message, Object context) { Console.Error.WriteLine(message); }
        public static void LogWarning(object message, Object context) { Console.Error.WriteLine("warning: " + message); }
        public static void LogError(object message, Object context) { Console.Error.WriteLine("error: " + message); }
    }

    [AttributeUsage(AttributeTargets.Field)] public sealed class SerializeField : Attribute { }
    [AttributeUsage(AttributeTargets.Field)] public sealed class HeaderAttribute : Attribute { public HeaderAttribute(string header) { } }
    [AttributeUsage(AttributeTargets.Field)] public sealed class TooltipAttribute : Attribute { public TooltipAttribute(string tooltip) { } }
    [AttributeUsage(AttributeTargets.Field)] public sealed class RangeAttribute : Attribute { public RangeAttribute(float min, float max) { } }
    [AttributeUsage(AttributeTargets.Field)] public sealed class MinAttribute : Attribute { public MinAttribute(float min) { } }
    [AttributeUsage(AttributeTargets.Class)] public sealed class AddComponentMenu : Attribute { public AddComponentMenu(string menuName) { } }
    [AttributeUsage(AttributeTargets.Class)] public sealed class DisallowMultipleComponent : Attribute { }
    [AttributeUsage(AttributeTargets.Class)] public sealed class HelpURLAttribute : Attribute { public HelpURLAttribute(string url) { } }
}

namespace UnityEngine.Rendering
{
    public enum AmbientMode { Skybox = 0, Trilight = 1, Flat = 3, Custom = 4 }

    public struct SphericalHarmonicsL2
    {
        float[] v; // the real type stores 27 floats shr0..shb8; indexer [rgb, coefficient]
        public float this[int rgb, int coefficient]
        {
            get { return v == null ? 0f : v[rgb * 9 + coefficient]; }
            set
            {
                if (rgb < 0 || rgb > 2 || coefficient < 0 || coefficient > 8) throw new IndexOutOfRangeException("Invalid index!");
                v = v == null ? new float[27] : (float[])v.Clone(); // copy-on-write: value semantics
                v[rgb * 9 + coefficient] = value;
            }
        }
    }
}
