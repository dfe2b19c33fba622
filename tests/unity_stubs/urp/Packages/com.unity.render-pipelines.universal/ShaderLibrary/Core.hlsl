// STAND-IN FOR URP's ShaderLibrary/Core.hlsl -- NOT UNITY'S FILE (URP is not in this repository).
// What tests/clients/unity/test_unity_shadow_catcher.py needs to compile Samples~/ShadowCatcher/SH9ShadowCatcherURP.shader:
// the functions it calls, with URP's signatures (com.unity.render-pipelines.universal 10-17,
// ShaderLibrary/ShaderVariablesFunctions.hlsl: GetVertexPositionInputs, VertexPositionInputs;
// core's SpaceTransforms.hlsl: TransformObjectToWorldNormal, TransformWorldToHClip;
// ComputeScreenPos), on top of the stand-in instancing and stereo macros of tests/unity_stubs
// (Unity's semantics: a pass that forgets a stereo step does not compile).
#ifndef UNIVERSAL_PIPELINE_CORE_INCLUDED
#define UNIVERSAL_PIPELINE_CORE_INCLUDED

#include "HLSLSupport.cginc"
#include "UnityShaderVariables.cginc"
#include "UnityInstancing.cginc"

#define real float
#define real4 float4

struct VertexPositionInputs
{
    float3 positionWS;
    float3 positionVS;
    float4 positionCS;
    float4 positionNDC;
};

float4 TransformWorldToHClip(float3 positionWS)
{
    return mul(UNITY_MATRIX_VP, float4(positionWS, 1.0));
}

float4 ComputeScreenPos(float4 positionCS)
{
    float4 o = positionCS * 0.5f;
    o.xy = float2(o.x, o.y * _ProjectionParams.x) + o.w;
    o.zw = positionCS.zw;
    return o;
}

VertexPositionInputs GetVertexPositionInputs(float3 positionOS)
{
    VertexPositionInputs input;
    input.positionWS = mul(unity_ObjectToWorld, float4(positionOS, 1.0)).xyz;
    input.positionVS = mul(UNITY_MATRIX_V, float4(input.positionWS, 1.0)).xyz;
    input.positionCS = TransformWorldToHClip(input.positionWS);
    input.positionNDC = ComputeScreenPos(input.positionCS);
    return input;
}

float3 TransformObjectToWorldNormal(float3 normalOS)
{
    return normalize(mul(normalOS, (float3x3)unity_WorldToObject));
}

#endif
