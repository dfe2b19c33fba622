// Shadow catcher for URP (issue 30; the sample's README.md): the same as the package's built-in
// "Shlight/SH9 Shadow Catcher" (unity_package/Shaders/SH9ShadowCatcher.shader): what is behind it is
// multiplied by SHShadowRatioOfSphere (sh9_lights.hlsl), V = URP's main-light shadow
// (MainLightRealtimeShadow: its cascades, soft-shadow filter and shadow strength), the main light being
// the Directional Light that SH9LightingClient drives from the key light (Key Light Shadows on); with an
// SH9ShadowOccluder on the hologram, lights 1..3 blocked by its bounding sphere (and the key light where
// it casts no shadow map), less the ambient the sphere hides.
// Blend factors from the material: Multiply (DstColor Zero, alpha kept) for a camera image in the
// framebuffer, Passthrough (black at coverage 1 − ratio) for a passthrough layer composited through the
// eye buffer's alpha (Quest). Additive displays (HoloLens) cannot darken: nothing shows there.
// It includes URP's ShaderLibrary, so it lives in a sample that URP projects import (a package shader
// with these includes would not compile in projects without URP).
Shader "Shlight/SH9 Shadow Catcher (URP)"
{
    Properties
    {
        _ShadowStrength ("Shadow strength (1: as measured)", Range(0, 1)) = 1
        [Enum(UnityEngine.Rendering.BlendMode)] _SrcBlend ("Colour source blend", Float) = 2
        [Enum(UnityEngine.Rendering.BlendMode)] _DstBlend ("Colour destination blend", Float) = 0
        [Enum(UnityEngine.Rendering.BlendMode)] _SrcBlendAlpha ("Alpha source blend", Float) = 0
        [Enum(UnityEngine.Rendering.BlendMode)] _DstBlendAlpha ("Alpha destination blend", Float) = 1
    }

    SubShader
    {
        Tags { "RenderPipeline" = "UniversalPipeline" "Queue" = "Geometry+10" "RenderType" = "Transparent" }
        LOD 100

        Pass
        {
            Name "SH9ShadowCatcher"
            Tags { "LightMode" = "UniversalForward" }
            Blend [_SrcBlend] [_DstBlend], [_SrcBlendAlpha] [_DstBlendAlpha]
            ZWrite Off
            ZTest LEqual
            Cull Back

            HLSLPROGRAM
            #pragma vertex SH9CatcherVertex
            #pragma fragment SH9CatcherFragment
            #pragma target 3.5
            #pragma multi_compile_instancing
            #pragma multi_compile _ _MAIN_LIGHT_SHADOWS _MAIN_LIGHT_SHADOWS_CASCADE _MAIN_LIGHT_SHADOWS_SCREEN
            #pragma multi_compile_fragment _ _SHADOWS_SOFT
            #include "Packages/com.unity.render-pipelines.universal/ShaderLibrary/Core.hlsl"
            #include "Packages/com.unity.render-pipelines.universal/ShaderLibrary/Shadows.hlsl"
            #include "Packages/org.shlight.sh9lighting/Shaders/sh9_lights.hlsl"

            CBUFFER_START(UnityPerMaterial)
            float _ShadowStrength;
            CBUFFER_END
            // global (outside UnityPerMaterial: SRP Batcher compatible), from SH9ShadowOccluder: the hologram's
            // bounding sphere in world space (xyz centre, w radius; w <= 0 or never set: no occluder)
            float4 _SHOccluderSphere;

            struct SH9CatcherAttributes
            {
                float4 positionOS : POSITION;
                float3 normalOS : NORMAL;
                UNITY_VERTEX_INPUT_INSTANCE_ID
            };

            struct SH9CatcherVaryings
            {
                float4 positionCS : SV_POSITION;
                float3 positionWS : TEXCOORD0;
                float3 normalWS : TEXCOORD1;
                float4 screenShadowCoord : TEXCOORD2;   // with _MAIN_LIGHT_SHADOWS_SCREEN only
                UNITY_VERTEX_OUTPUT_STEREO
            };

            SH9CatcherVaryings SH9CatcherVertex(SH9CatcherAttributes v)
            {
                SH9CatcherVaryings o = (SH9CatcherVaryings)0;
                UNITY_SETUP_INSTANCE_ID(v);
                UNITY_INITIALIZE_VERTEX_OUTPUT_STEREO(o);
                VertexPositionInputs p = GetVertexPositionInputs(v.positionOS.xyz);
                o.positionCS = p.positionCS;
                o.positionWS = p.positionWS;
                o.normalWS = TransformObjectToWorldNormal(v.normalOS);
                o.screenShadowCoord = GetShadowCoord(p);
                return o;
            }

            float4 SH9CatcherFragment(SH9CatcherVaryings i) : SV_Target
            {
                UNITY_SETUP_STEREO_EYE_INDEX_POST_VERTEX(i);
            #if defined(_MAIN_LIGHT_SHADOWS_SCREEN)
                float4 shadowCoord = i.screenShadowCoord;
            #else
                float4 shadowCoord = TransformWorldToShadowCoord(i.positionWS);   // per pixel: the right cascade
            #endif
                float3 n = normalize(i.normalWS);
            #if defined(_MAIN_LIGHT_SHADOWS) || defined(_MAIN_LIGHT_SHADOWS_CASCADE) || defined(_MAIN_LIGHT_SHADOWS_SCREEN)
                float keyVisibility = MainLightRealtimeShadow(shadowCoord);   // the hologram's real shape
            #else
                // no shadow map for the key light: its disc's share left by the occluder sphere (1 without one)
                float keyVisibility = SHSphereLightVisibility(i.positionWS, _SHOccluderSphere, _SHLightDirection[0].xyz,
                                                              _SHLightAngularRadius.x);
            #endif
                // lights 1..3 past the hologram's bounding sphere (set by SH9ShadowOccluder), and the ambient it hides;
                // SH9LightingClient keeps lights 1..3 in the SH9 globals too (folded), which this takes out again
                float3 ratio = SHShadowRatioOfSphere(n, i.positionWS, _SHOccluderSphere, keyVisibility, _ShadowStrength);
                return float4(ratio, 1.0 - dot(ratio, float3(0.2126, 0.7152, 0.0722)));
            }
            ENDHLSL
        }
    }
    Fallback Off
}
