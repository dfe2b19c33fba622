// Which MRTK shaders ignore Unity's ambient probe unless a per-material switch is on, and the
// names of that switch (plain C#, no UnityEngine; SH9MrtkAmbient applies it to materials).
//
// Names read at their source:
//  * MRTK2 "Mixed Reality Toolkit/Standard": microsoft/MixedRealityToolkit-Unity,
//    Assets/MRTK/Core/StandardAssets/Shaders/MixedRealityStandard.shader (commit a460bae9):
//    line 30 `[Toggle(_SPHERICAL_HARMONICS)] _SphericalHarmonics("Spherical Harmonics", Float) = 0.0`;
//    the vertex stage computes `o.ambient = ShadeSH9(float4(worldNormal, 1.0))` only under
//    _SPHERICAL_HARMONICS and otherwise uses `glstate_lightmodel_ambient + 0.25`. The ambient reaches
//    the surface with or without its directional light (`#elif defined(_SPHERICAL_HARMONICS)`).
//  * MRTK3 Graphics Tools (com.microsoft.mrtk.graphicstools.unity 0.8.8,
//    microsoft/MixedReality-GraphicsTools-Unity commit bc81f919), Runtime/Shaders:
//    GraphicsToolsStandard.shader line 38, GraphicsToolsStandardNonSrp.shader line 38,
//    GraphicsToolsStandardCanvas.shader line 39, GraphicsToolsStandardCanvasNonSrp.shader line 39:
//    the same `[Toggle(_SPHERICAL_HARMONICS)] _SphericalHarmonics` (a `shader_feature_local`,
//    GraphicsToolsStandardProgram.hlsl line 43). There the SH ambient is used only inside
//    `#if defined(_DIRECTIONAL_LIGHT) || defined(_DISTANT_LIGHT)` (GraphicsToolsStandardProgram.hlsl
//    lines 779-787): a material whose "Light Mode" is Unlit shows no ambient at all.
//
// The "Reflections" option (SH9MrtkAmbient's opt-in), read at the same sources:
//  * MRTK2: line 31 `[Toggle(_REFLECTIONS)] _Reflections("Reflections", Float) = 0.0`. Under _REFLECTIONS
//    the fragment samples `UNITY_SAMPLE_TEXCUBE_LOD(unity_SpecCube0, reflect(incident, worldNormal),
//    (1.0 - _Smoothness) * UNITY_SPECCUBE_LOD_STEPS)` and decodes it with unity_SpecCube0_HDR; without
//    it, `ibl = unity_IndirectSpecColor.rgb` (a constant). The lod is LINEAR in perceptual roughness,
//    not Unity's ρ(1.7 − 0.7ρ) curve. The reflection is mixed by `minProperty = min(_Smoothness,
//    _Metallic)` (`lerp(albedo, ibl, minProperty)`), plus `ibl * (1 - _Metallic) * 0.1`
//    (_IblContribution) with the Directional Light on; with it off a material of Metallic 0 shows no
//    reflection. (Line numbers of the fragment code, as counted in MRTK 2.5.1's copy of the same file,
//    provencher/MRTK-Quest-Sample Assets/MRTK/Shaders/MixedRealityStandard.shader @ d2e35d8: lod
//    1040-1051, mix 1069-1084; the code is the same at a460bae9.)
//  * Graphics Tools: GraphicsToolsStandard*.shader line 40 `[Toggle(_REFLECTIONS)] _Reflections`
//    (`shader_feature_local _REFLECTIONS`, GraphicsToolsStandardProgram.hlsl line 44).
//    GraphicsToolsLighting.hlsl lines 121-126 (GTPerceptualRoughnessToMipmapLevel: ρ(1.7 − 0.7ρ)·
//    UNITY_SPECCUBE_LOD_STEPS, Unity's curve) and 128-157 (GTGlossyEnvironmentReflection: under
//    _REFLECTIONS, unity_SpecCube0 at that lod, DecodeHDREnvironment / DecodeHDR with
//    unity_SpecCube0_HDR; otherwise _GlossyEnvironmentColor (URP) / unity_IndirectSpecColor), with
//    ρ = 1 − _Smoothness (lines 81-84). Lit (GraphicsToolsStandardProgram.hlsl 779-799): the reflection
//    is the indirect specular of GTGlobalIllumination (a URP-like environment BRDF); Unlit (800-804):
//    `albedo * 0.5 + reflection * (_Smoothness + _Metallic) * 0.5`. No box projection, no probe
//    blending, no URP reflection keyword: just unity_SpecCube0.
using System;

namespace Shlight.Lighting
{
    /// <summary>How an MRTK shader's "Reflections" option reads and mixes unity_SpecCube0.</summary>
    public enum Sh9MrtkReflectionModel
    {
        /// <summary>Graphics Tools: lod ρ(1.7 − 0.7ρ)·6 (Unity's curve), ρ = 1 − Smoothness; an environment BRDF.</summary>
        GraphicsTools = 0,
        /// <summary>MRTK2: lod (1 − Smoothness)·6 (linear); mixed by min(Smoothness, Metallic).</summary>
        Mrtk2 = 1,
    }

    /// <summary>One shader family whose materials need a switch before they use the ambient probe.</summary>
    public sealed class Sh9AmbientSwitch
    {
        /// <summary>Shader name as Shader.Find knows it.</summary>
        public readonly string ShaderName;
        /// <summary>The material's float property behind the toggle (1 = on).</summary>
        public readonly string Property;
        /// <summary>The shader keyword the toggle enables.</summary>
        public readonly string Keyword;
        /// <summary>Keywords of which at least one must be on for the ambient to show (empty: none needed).</summary>
        public readonly string[] NeedsOneOf;
        /// <summary>Where the names were read.</summary>
        public readonly string Source;
        /// <summary>The "Reflections" toggle's float property (1 = on): unity_SpecCube0 is sampled only then.</summary>
        public readonly string ReflectionsProperty = "_Reflections";
        /// <summary>The keyword the "Reflections" toggle enables.</summary>
        public readonly string ReflectionsKeyword = "_REFLECTIONS";
        /// <summary>How the shader reads and mixes the reflection cube.</summary>
        public readonly Sh9MrtkReflectionModel Reflection;

        public Sh9AmbientSwitch(string shaderName, string property, string keyword, string[] needsOneOf, string source,
                                Sh9MrtkReflectionModel reflection)
        {
            Reflection = reflection;
            ShaderName = shaderName;
            Property = property;
            Keyword = keyword;
            NeedsOneOf = needsOneOf ?? new string[0];
            Source = source;
        }
    }

    public static class Sh9MrtkShaders
    {
        static readonly string[] GraphicsToolsLit = { "_DIRECTIONAL_LIGHT", "_DISTANT_LIGHT" };

        /// <summary>The shaders handled, MRTK2 first.</summary>
        public static readonly Sh9AmbientSwitch[] Known =
        {
            new Sh9AmbientSwitch("Mixed Reality Toolkit/Standard", "_SphericalHarmonics", "_SPHERICAL_HARMONICS", null,
                                 "MRTK2 MixedRealityStandard.shader:30",
                                 Sh9MrtkReflectionModel.Mrtk2),
            new Sh9AmbientSwitch("Graphics Tools/Standard", "_SphericalHarmonics", "_SPHERICAL_HARMONICS", GraphicsToolsLit,
                                 "MRTK3 Graphics Tools GraphicsToolsStandard.shader:38", Sh9MrtkReflectionModel.GraphicsTools),
            new Sh9AmbientSwitch("Graphics Tools/Non-SRP/StandardNonSrp", "_SphericalHarmonics", "_SPHERICAL_HARMONICS", GraphicsToolsLit,
                                 "MRTK3 Graphics Tools GraphicsToolsStandardNonSrp.shader:38", Sh9MrtkReflectionModel.GraphicsTools),
            new Sh9AmbientSwitch("Graphics Tools/Standard Canvas", "_SphericalHarmonics", "_SPHERICAL_HARMONICS", GraphicsToolsLit,
                                 "MRTK3 Graphics Tools GraphicsToolsStandardCanvas.shader:39", Sh9MrtkReflectionModel.GraphicsTools),
            new Sh9AmbientSwitch("Graphics Tools/Non-SRP/Standard CanvasNonSrp", "_SphericalHarmonics", "_SPHERICAL_HARMONICS", GraphicsToolsLit,
                                 "MRTK3 Graphics Tools GraphicsToolsStandardCanvasNonSrp.shader:39", Sh9MrtkReflectionModel.GraphicsTools),
        };

        /// <summary>
        /// The perceptual roughness whose prefiltered radiance a material of this smoothness reflects from
        /// a cube whose mips follow Unity's curve (SH9Reflections' cube, and any probe Unity bakes):
        /// 1 − s for Graphics Tools (it reads the cube on Unity's curve); for MRTK2, which reads lod
        /// (1 − s)·6, the ρ with ρ(1.7 − 0.7ρ) = 1 − s (glossier: s = 0.5 reflects roughness 0.34).
        /// </summary>
        public static double ReflectedRoughness(Sh9AmbientSwitch shader, double smoothness)
        {
            double rho = Math.Max(0.0, Math.Min(1.0, 1.0 - smoothness));
            if (shader == null || shader.Reflection != Sh9MrtkReflectionModel.Mrtk2) return rho;
            return Sh9UnityCubeBaker.UnityLevelRoughness(rho * Sh9UnityCubeBaker.UnityLodSteps);
        }

        /// <summary>The MRTK2 smoothness that reflects perceptual roughness ρ as Unity's Standard / URP Lit /
        /// Graphics Tools do with smoothness 1 − ρ: 1 − ρ(1.7 − 0.7ρ).</summary>
        public static double Mrtk2SmoothnessForRoughness(double roughness)
        {
            double rho = Math.Max(0.0, Math.Min(1.0, roughness));
            return 1.0 - rho * (1.7 - 0.7 * rho);
        }

        /// <summary>The switch for a shader name, or null when the shader is not one of <see cref="Known"/>.</summary>
        public static Sh9AmbientSwitch Find(string shaderName)
        {
            if (string.IsNullOrEmpty(shaderName)) return null;
            for (int i = 0; i < Known.Length; i++)
                if (string.Equals(Known[i].ShaderName, shaderName, StringComparison.Ordinal)) return Known[i];
            return null;
        }
    }
}
