// Makes Unity's ambient probe (set by SH9LightingClient's "Drive Ambient Probe") reach MRTK
// materials: MRTK2's "Mixed Reality Toolkit/Standard" and MRTK3 Graphics Tools' "Graphics
// Tools/Standard" (and their Canvas / Non-SRP versions) ignore the ambient probe unless each
// material's "Spherical Harmonics" toggle is on, and it is off by default (names and sources:
// Runtime/Core/Sh9MrtkShaders.cs). Optionally also makes renderers take the ambient probe instead of
// baked light probes (a renderer that blends light probes never sees the ambient probe), and, opt-in
// (Also Reflections), switches on each MRTK material's "Reflections" option, without which these
// shaders never sample unity_SpecCube0, i.e. never show the room cube SH9Reflections gives Unity
// (sources and how each shader reads the cube: Runtime/Core/Sh9MrtkShaders.cs).
//
// The materials changed are shared assets: everything is put back in OnDisable (leaving Play mode
// included), so the project's materials are not left modified.
using System.Collections.Generic;
using UnityEngine;
using UnityEngine.Rendering;

namespace Shlight.Lighting
{
    [AddComponentMenu("Lighting/SH9 Ambient for MRTK Materials (shlight)")]
    [DisallowMultipleComponent]
    public sealed class SH9MrtkAmbient : MonoBehaviour
    {
        public enum Scope
        {
            /// <summary>Renderers under this GameObject (itself included), active or not.</summary>
            ChildrenOfThisObject = 0,
            /// <summary>Every loaded renderer (Object.FindObjectsOfType), when enabled.</summary>
            WholeScene = 1,
        }

        [Tooltip("Which renderers to look at when enabled (call Apply() again for objects spawned later).")]
        [SerializeField] Scope scope = Scope.WholeScene;
        [Tooltip("Also set each renderer's Light Probes to Off, so that it gets the ambient probe rather than " +
                 "baked light probes (only matters in scenes with baked light probes).")]
        [SerializeField] bool ambientProbeInsteadOfLightProbes = true;
        [Tooltip("Also switch on each MRTK material's \"Reflections\" option, so that it reflects the scene's " +
                 "reflection cube (unity_SpecCube0: SH9Reflections' room cube). MRTK2 mixes it by min(Smoothness, " +
                 "Metallic): materials of Metallic 0 show it only faintly (listed in the report).")]
        [SerializeField] bool alsoReflections = false;
        [SerializeField] bool logReport = true;

        struct SavedToggle { public bool Changed, HadProperty, Keyword; public float Value; }
        struct SavedMaterial { public Material Material; public Sh9AmbientSwitch Switch; public SavedToggle SH, Reflections; }
        struct SavedRenderer { public Renderer Renderer; public LightProbeUsage Usage; }

        readonly List<SavedMaterial> savedMaterials = new List<SavedMaterial>();
        readonly List<SavedRenderer> savedRenderers = new List<SavedRenderer>();
        readonly HashSet<Material> seen = new HashSet<Material>();
        readonly HashSet<Renderer> seenRenderers = new HashSet<Renderer>();

        /// <summary>MRTK materials switched on by this component (and put back on disable).</summary>
        public int MaterialsSwitched { get; private set; }
        /// <summary>MRTK materials that already had spherical harmonics on.</summary>
        public int MaterialsAlreadyOn { get; private set; }
        /// <summary>MRTK3 materials whose Light Mode is Unlit: the ambient cannot show on them (their
        /// shader reads it only when lit); left unlit, listed in <see cref="LastReport"/>.</summary>
        public int MaterialsUnlit { get; private set; }
        /// <summary>Renderers switched from light probes to the ambient probe.</summary>
        public int RenderersSwitched { get; private set; }
        /// <summary>MRTK materials whose "Reflections" option this component switched on (Also Reflections).</summary>
        public int ReflectionsSwitched { get; private set; }
        /// <summary>MRTK materials that already had "Reflections" on (Also Reflections).</summary>
        public int ReflectionsAlreadyOn { get; private set; }
        /// <summary>MRTK2 materials (no channel map) of Metallic 0: MRTK2 mixes the reflection by
        /// min(Smoothness, Metallic), so they show it only as 10% with the Directional Light on and not at all
        /// without (listed in <see cref="LastReport"/>).</summary>
        public int ReflectionsFaint { get; private set; }
        /// <summary>What the last Apply did, in words.</summary>
        public string LastReport { get; private set; }

        public Scope Search { get { return scope; } set { scope = value; } }
        public bool AmbientProbeInsteadOfLightProbes
        {
            get { return ambientProbeInsteadOfLightProbes; }
            set { ambientProbeInsteadOfLightProbes = value; }
        }
        /// <summary>Also switch on the materials' "Reflections" option (takes effect at the next Apply).</summary>
        public bool AlsoReflections { get { return alsoReflections; } set { alsoReflections = value; } }

        void OnEnable() { Apply(); }

        void OnDisable() { Restore(); }

        /// <summary>Switch on the ambient for the renderers in <see cref="Search"/> scope.</summary>
        public void Apply()
        {
            Apply(scope == Scope.WholeScene ? FindObjectsOfType<Renderer>() : GetComponentsInChildren<Renderer>(true));
        }

        /// <summary>Switch on the ambient for these renderers (e.g. a hologram spawned after enable).
        /// Each material and renderer is changed (and remembered) once.</summary>
        public void Apply(Renderer[] renderers)
        {
            var unlit = new List<string>();
            var faint = new List<string>();
            foreach (Renderer r in renderers)
            {
                if (r == null) continue;
                foreach (Material m in r.sharedMaterials)
                {
                    if (m == null || !seen.Add(m)) continue;
                    Sh9AmbientSwitch sw = Sh9MrtkShaders.Find(m.shader == null ? null : m.shader.name);
                    if (sw == null) continue;
                    var saved = new SavedMaterial { Material = m, Switch = sw, SH = Save(m, sw.Property, sw.Keyword) };
                    if (IsOn(saved.SH)) MaterialsAlreadyOn++;
                    else
                    {
                        saved.SH.Changed = true;
                        EnableSphericalHarmonics(m);
                        MaterialsSwitched++;
                    }
                    if (alsoReflections)
                    {
                        saved.Reflections = Save(m, sw.ReflectionsProperty, sw.ReflectionsKeyword);
                        if (IsOn(saved.Reflections)) ReflectionsAlreadyOn++;
                        else
                        {
                            saved.Reflections.Changed = true;
                            EnableReflections(m);
                            ReflectionsSwitched++;
                        }
                        if (Faint(m, sw))
                        {
                            ReflectionsFaint++;
                            faint.Add(m.name);
                        }
                    }
                    if (saved.SH.Changed || saved.Reflections.Changed) savedMaterials.Add(saved);
                    if (!Shows(m, sw))
                    {
                        MaterialsUnlit++;
                        unlit.Add(m.name);
                    }
                }
                if (ambientProbeInsteadOfLightProbes && seenRenderers.Add(r) && r.lightProbeUsage != LightProbeUsage.Off)
                {
                    savedRenderers.Add(new SavedRenderer { Renderer = r, Usage = r.lightProbeUsage });
                    r.lightProbeUsage = LightProbeUsage.Off;
                    RenderersSwitched++;
                }
            }
            LastReport = "spherical harmonics switched on in " + MaterialsSwitched + " MRTK material(s), " +
                         MaterialsAlreadyOn + " already on; " + RenderersSwitched + " renderer(s) moved from light " +
                         "probes to the ambient probe" +
                         (unlit.Count > 0 ? "; no effect on unlit MRTK3 material(s) (set Light Mode to Lit Directional): " +
                                            string.Join(", ", unlit.ToArray()) : "") +
                         (alsoReflections ? "; reflections switched on in " + ReflectionsSwitched + " MRTK material(s), " +
                                            ReflectionsAlreadyOn + " already on" : "") +
                         (faint.Count > 0 ? "; MRTK2 material(s) of Metallic 0 reflect only faintly (MRTK2 mixes the " +
                                            "reflection by min(Smoothness, Metallic)): " + string.Join(", ", faint.ToArray()) : "");
            if (logReport) Debug.Log("[SH9] " + LastReport, this);
        }

        /// <summary>
        /// Turn on one material's spherical harmonics (the "Spherical Harmonics" toggle: its float
        /// property and its keyword). False when the material's shader is not one MRTK shader this
        /// package knows (Sh9MrtkShaders.Known); then nothing is changed.
        /// </summary>
        public static bool EnableSphericalHarmonics(Material material)
        {
            if (material == null) return false;
            Sh9AmbientSwitch sw = Sh9MrtkShaders.Find(material.shader == null ? null : material.shader.name);
            if (sw == null) return false;
            if (material.HasProperty(sw.Property)) material.SetFloat(sw.Property, 1f);
            material.EnableKeyword(sw.Keyword);
            return true;
        }

        /// <summary>
        /// Turn on one material's "Reflections" option (its float property and keyword), without which MRTK2's
        /// and Graphics Tools' Standard shaders never sample unity_SpecCube0. False (nothing changed) when the
        /// material's shader is not one MRTK shader this package knows.
        /// </summary>
        public static bool EnableReflections(Material material)
        {
            if (material == null) return false;
            Sh9AmbientSwitch sw = Sh9MrtkShaders.Find(material.shader == null ? null : material.shader.name);
            if (sw == null) return false;
            if (material.HasProperty(sw.ReflectionsProperty)) material.SetFloat(sw.ReflectionsProperty, 1f);
            material.EnableKeyword(sw.ReflectionsKeyword);
            return true;
        }

        static SavedToggle Save(Material m, string property, string keyword)
        {
            bool has = m.HasProperty(property);
            return new SavedToggle { HadProperty = has, Value = has ? m.GetFloat(property) : 0f, Keyword = m.IsKeywordEnabled(keyword) };
        }

        static bool IsOn(SavedToggle s) { return s.Keyword && (!s.HadProperty || s.Value >= 0.5f); }

        static void Put(Material m, SavedToggle s, string property, string keyword)
        {
            if (!s.Changed) return;
            if (s.HadProperty) m.SetFloat(property, s.Value);
            if (!s.Keyword) m.DisableKeyword(keyword);
        }

        static bool Faint(Material m, Sh9AmbientSwitch sw)
        {
            return sw.Reflection == Sh9MrtkReflectionModel.Mrtk2 && !m.IsKeywordEnabled("_CHANNEL_MAP") &&
                   m.HasProperty("_Metallic") && m.GetFloat("_Metallic") <= 0f;
        }

        static bool Shows(Material m, Sh9AmbientSwitch sw)
        {
            if (sw.NeedsOneOf.Length == 0) return true;
            foreach (string k in sw.NeedsOneOf) if (m.IsKeywordEnabled(k)) return true;
            return false;
        }

        /// <summary>Put every material and renderer changed by this component back as it was.</summary>
        public void Restore()
        {
            foreach (SavedMaterial s in savedMaterials)
            {
                if (s.Material == null) continue;
                Put(s.Material, s.SH, s.Switch.Property, s.Switch.Keyword);
                Put(s.Material, s.Reflections, s.Switch.ReflectionsProperty, s.Switch.ReflectionsKeyword);
            }
            foreach (SavedRenderer s in savedRenderers)
                if (s.Renderer != null) s.Renderer.lightProbeUsage = s.Usage;
            savedMaterials.Clear();
            savedRenderers.Clear();
            seen.Clear();
            seenRenderers.Clear();
            MaterialsSwitched = MaterialsAlreadyOn = MaterialsUnlit = RenderersSwitched = 0;
            ReflectionsSwitched = ReflectionsAlreadyOn = ReflectionsFaint = 0;
        }
    }
}
