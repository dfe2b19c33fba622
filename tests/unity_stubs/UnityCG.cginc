// COMPILE-ONLY STAND-IN FOR Unity's UnityCG.cginc -- NOT UNITY.
// Just enough declarations and macros for glslangValidator's HLSL front end to type-check the
// package's SH9Diffuse.shader program (tests/test_unity.py). The stereo/instancing macros are
// defined the way Unity defines them when instancing is off (empty), so only the shader's own
// code is checked, not Unity's.
#ifndef UNITY_CG_STANDIN_INCLUDED
#define UNITY_CG_STANDIN_INCLUDED

#define UNITY_PI 3.14159265359f
#define fixed half
#define fixed2 half2
#define fixed3 half3
#define fixed4 half4

float4x4 unity_ObjectToWorld;
float4x4 unity_WorldToObject;
float4x4 unity_MatrixVP;

#define UNITY_VERTEX_INPUT_INSTANCE_ID
#define UNITY_VERTEX_OUTPUT_STEREO
#define UNITY_SETUP_INSTANCE_ID(v)
#define UNITY_TRANSFER_INSTANCE_ID(v, o)
#define UNITY_INITIALIZE_VERTEX_OUTPUT_STEREO(o)
#define UNITY_SETUP_STEREO_EYE_INDEX_POST_VERTEX(i)
#define UNITY_INITIALIZE_OUTPUT(type, name) name = (type)0
#define TRANSFORM_TEX(tex, name) (tex.xy * name##_ST.xy + name##_ST.zw)

float4 UnityObjectToClipPos(float4 pos)
{
    return mul(unity_MatrixVP, mul(unity_ObjectToWorld, float4(pos.xyz, 1.0)));
}

float3 UnityObjectToWorldNormal(float3 n)
{
    return normalize(mul(n, (float3x3)unity_WorldToObject));
}

half3 GammaToLinearSpace(half3 c)
{
    return c * (c * (c * 0.305306011h + 0.682171111h) + 0.012522878h);
}

half3 LinearToGammaSpace(half3 c)
{
    c = max(c, half3(0.h, 0.h, 0.h));
    return max(1.055h * pow(c, 0.416666667h) - 0.055h, 0.h);
}

#endif
