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
using System;

namespace Shlight.Lighting
{
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

        public Sh9AmbientSwitch(string shaderName, string property, string keyword, string[] needsOneOf, string source)
        {
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
                                 "MRTK2 MixedRealityStandard.shader:30"),
            new Sh9AmbientSwitch("Graphics Tools/Standard", "_SphericalHarmonics", "_SPHERICAL_HARMONICS", GraphicsToolsLit,
                                 "MRTK3 Graphics Tools GraphicsToolsStandard.shader:38"),
            new Sh9AmbientSwitch("Graphics Tools/Non-SRP/StandardNonSrp", "_SphericalHarmonics", "_SPHERICAL_HARMONICS", GraphicsToolsLit,
                                 "MRTK3 Graphics Tools GraphicsToolsStandardNonSrp.shader:38"),
            new Sh9AmbientSwitch("Graphics Tools/Standard Canvas", "_SphericalHarmonics", "_SPHERICAL_HARMONICS", GraphicsToolsLit,
                                 "MRTK3 Graphics Tools GraphicsToolsStandardCanvas.shader:39"),
            new Sh9AmbientSwitch("Graphics Tools/Non-SRP/Standard CanvasNonSrp", "_SphericalHarmonics", "_SPHERICAL_HARMONICS", GraphicsToolsLit,
                                 "MRTK3 Graphics Tools GraphicsToolsStandardCanvasNonSrp.shader:39"),
        };

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
