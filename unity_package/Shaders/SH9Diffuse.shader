// Diffuse (Lambertian) surface lit by the room: radiance = albedo · (E(n)/π + main light · N·L),
// with E(n) from the three SH9 irradiance matrices that SH9LightingClient sets as globals
// (sh9_irradiance.hlsl) and the main directional light only while that component drives it from
// the server's lights (_SHMainLightScale). The passes are in SH9DiffusePasses.hlsl.
//
// * URP (first SubShader, picked by URP through its RenderPipeline tag): the colour pass (no
//   LightMode tag: URP draws it as SRPDefaultUnlit), ShadowCaster,
//   DepthOnly (needed with depth priming) and DepthNormals; SRP Batcher layout (UnityPerMaterial).
// * Built-in pipeline (second SubShader; the built-in pipeline skips the URP one): ForwardBase
//   (for the main directional light) and ShadowCaster.
// * HoloLens single-pass instanced stereo and multiview in every pass; GPU instancing with a
//   per-instance _Color; gamma and linear colour space (lighting in linear, encoded at the end).
// Only Unity's built-in CGIncludes are used, so the shader compiles with or without URP installed.
Shader "Shlight/SH9 Diffuse"
{
    Properties
    {
        _Color ("Albedo colour", Color) = (1, 1, 1, 1)
        _MainTex ("Albedo (RGB)", 2D) = "white" {}
        _Exposure ("Exposure (linear)", Float) = 1.0
    }

    SubShader
    {
        Tags { "RenderPipeline" = "UniversalPipeline" "RenderType" = "Opaque" "Queue" = "Geometry" }
        LOD 100

        Pass
        {
            Name "SH9Diffuse"
            ZWrite On
            Cull Back

            CGPROGRAM
            #pragma vertex SH9ForwardVertex
            #pragma fragment SH9ForwardFragment
            #pragma target 3.5
            #pragma multi_compile_instancing
            #pragma multi_compile_fragment _ SH9_PASSTHROUGH
            #define SH9_URP
            #include "SH9DiffusePasses.hlsl"
            ENDCG
        }

        Pass
        {
            Name "ShadowCaster"
            Tags { "LightMode" = "ShadowCaster" }
            ZWrite On
            ZTest LEqual
            ColorMask 0
            Cull Back

            CGPROGRAM
            #pragma vertex SH9ShadowVertex
            #pragma fragment SH9ShadowFragment
            #pragma target 3.5
            #pragma multi_compile_instancing
            #pragma multi_compile_vertex _ _CASTING_PUNCTUAL_LIGHT_SHADOW
            #define SH9_URP
            #include "SH9DiffusePasses.hlsl"
            ENDCG
        }

        Pass
        {
            Name "DepthOnly"
            Tags { "LightMode" = "DepthOnly" }
            ZWrite On
            ColorMask R
            Cull Back

            CGPROGRAM
            #pragma vertex SH9DepthOnlyVertex
            #pragma fragment SH9DepthOnlyFragment
            #pragma target 3.5
            #pragma multi_compile_instancing
            #define SH9_URP
            #include "SH9DiffusePasses.hlsl"
            ENDCG
        }

        Pass
        {
            Name "DepthNormals"
            Tags { "LightMode" = "DepthNormals" }
            ZWrite On
            Cull Back

            CGPROGRAM
            #pragma vertex SH9DepthNormalsVertex
            #pragma fragment SH9DepthNormalsFragment
            #pragma target 3.5
            #pragma multi_compile_instancing
            #pragma multi_compile_fragment _ _GBUFFER_NORMALS_OCT
            #define SH9_URP
            #include "SH9DiffusePasses.hlsl"
            ENDCG
        }
    }

    SubShader
    {
        Tags { "RenderType" = "Opaque" "Queue" = "Geometry" }
        LOD 100

        Pass
        {
            Name "SH9Diffuse"
            Tags { "LightMode" = "ForwardBase" }
            ZWrite On
            Cull Back

            CGPROGRAM
            #pragma vertex SH9ForwardVertex
            #pragma fragment SH9ForwardFragment
            #pragma target 3.5
            #pragma multi_compile_instancing
            #pragma multi_compile_fragment _ SH9_PASSTHROUGH
            #include "SH9DiffusePasses.hlsl"
            ENDCG
        }

        Pass
        {
            Name "ShadowCaster"
            Tags { "LightMode" = "ShadowCaster" }
            ZWrite On
            ZTest LEqual
            Cull Back

            CGPROGRAM
            #pragma vertex SH9ShadowVertex
            #pragma fragment SH9ShadowFragment
            #pragma target 3.5
            #pragma multi_compile_instancing
            #pragma multi_compile_shadowcaster
            #include "SH9DiffusePasses.hlsl"
            ENDCG
        }
    }
    FallBack Off
}
