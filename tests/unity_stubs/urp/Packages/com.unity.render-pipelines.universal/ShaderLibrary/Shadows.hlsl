// STAND-IN FOR URP's ShaderLibrary/Shadows.hlsl -- NOT UNITY'S FILE (URP is not in this repository).
// URP's main-light shadow declarations and the three functions SH9ShadowCatcherURP.shader calls, with
// URP's signatures (URP 10-17): TransformWorldToShadowCoord(float3) -> float4 (the cascade's shadow
// coordinate), GetShadowCoord(VertexPositionInputs) -> float4 (screen position with
// _MAIN_LIGHT_SHADOWS_SCREEN), MainLightRealtimeShadow(float4) -> half (1 open, 0 blocked, 1 without
// shadow keywords); MAIN_LIGHT_CALCULATE_SHADOWS as URP defines it from the keywords.
#ifndef UNIVERSAL_SHADOWS_INCLUDED
#define UNIVERSAL_SHADOWS_INCLUDED

#include "Core.hlsl"

#define MAX_SHADOW_CASCADES 4

#if !defined(_RECEIVE_SHADOWS_OFF)
    #if defined(_MAIN_LIGHT_SHADOWS) || defined(_MAIN_LIGHT_SHADOWS_CASCADE) || defined(_MAIN_LIGHT_SHADOWS_SCREEN)
        #define MAIN_LIGHT_CALCULATE_SHADOWS
    #endif
#endif

Texture2D _MainLightShadowmapTexture;
SamplerComparisonState sampler_LinearClampCompare;
Texture2D _ScreenSpaceShadowmapTexture;
SamplerState sampler_PointClamp;

CBUFFER_START(LightShadows)
float4x4 _MainLightWorldToShadow[MAX_SHADOW_CASCADES + 1];
float4 _CascadeShadowSplitSpheres0;
float4 _CascadeShadowSplitSpheres1;
float4 _CascadeShadowSplitSpheres2;
float4 _CascadeShadowSplitSpheres3;
float4 _CascadeShadowSplitSphereRadii;
float4 _MainLightShadowParams;
CBUFFER_END

half ComputeCascadeIndex(float3 positionWS)
{
    float3 fromCenter0 = positionWS - _CascadeShadowSplitSpheres0.xyz;
    float3 fromCenter1 = positionWS - _CascadeShadowSplitSpheres1.xyz;
    float3 fromCenter2 = positionWS - _CascadeShadowSplitSpheres2.xyz;
    float3 fromCenter3 = positionWS - _CascadeShadowSplitSpheres3.xyz;
    float4 distances2 = float4(dot(fromCenter0, fromCenter0), dot(fromCenter1, fromCenter1),
                               dot(fromCenter2, fromCenter2), dot(fromCenter3, fromCenter3));
    half4 weights = half4(distances2 < _CascadeShadowSplitSphereRadii);
    weights.yzw = saturate(weights.yzw - weights.xyz);
    return half(4.0) - dot(weights, half4(4, 3, 2, 1));
}

float4 TransformWorldToShadowCoord(float3 positionWS)
{
#ifdef _MAIN_LIGHT_SHADOWS_CASCADE
    half cascadeIndex = ComputeCascadeIndex(positionWS);
#else
    half cascadeIndex = half(0.0);
#endif
    float4 shadowCoord = mul(_MainLightWorldToShadow[cascadeIndex], float4(positionWS, 1.0));
    return float4(shadowCoord.xyz, 0);
}

float4 GetShadowCoord(VertexPositionInputs vertexInput)
{
#if defined(_MAIN_LIGHT_SHADOWS_SCREEN) && !defined(_SURFACE_TYPE_TRANSPARENT)
    return ComputeScreenPos(vertexInput.positionCS);
#else
    return TransformWorldToShadowCoord(vertexInput.positionWS);
#endif
}

half MainLightRealtimeShadow(float4 shadowCoord)
{
#if !defined(MAIN_LIGHT_CALCULATE_SHADOWS)
    return half(1.0);
#elif defined(_MAIN_LIGHT_SHADOWS_SCREEN) && !defined(_SURFACE_TYPE_TRANSPARENT)
    return _ScreenSpaceShadowmapTexture.Sample(sampler_PointClamp, shadowCoord.xy / shadowCoord.w).x;
#else
    half attenuation = _MainLightShadowmapTexture.SampleCmpLevelZero(sampler_LinearClampCompare, shadowCoord.xy, shadowCoord.z);
    return lerp(1.0, attenuation, _MainLightShadowParams.x);
#endif
}

#endif
