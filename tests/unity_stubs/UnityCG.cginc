// STAND-IN FOR Unity's CGIncludes/UnityCG.cginc -- NOT UNITY'S FILE.
// The functions and macros of UnityCG.cginc (with UnityShaderUtilities.cginc) that the package's
// shaders use, written from a reading of Unity's built-in shader includes (2022.3 line numbers).
// It includes the stand-in UnityShaderVariables/UnityInstancing, which define the stereo and
// instancing macros as Unity does, so that the shader's stereo and instancing code is checked.
#ifndef UNITY_CG_INCLUDED
#define UNITY_CG_INCLUDED

#define UNITY_PI 3.14159265359f

#include "UnityShaderVariables.cginc"

// UnityShaderUtilities.cginc lines 46-58 (replaced by the instanced version with INSTANCING_ON)
inline float4 UnityObjectToClipPos(in float3 pos)
{
    return mul(UNITY_MATRIX_VP, mul(unity_ObjectToWorld, float4(pos, 1.0)));
}
inline float4 UnityObjectToClipPos(float4 pos) { return UnityObjectToClipPos(pos.xyz); }

#include "UnityInstancing.cginc"

// lines 97-131: sRGB curves
inline float GammaToLinearSpaceExact(float value)
{
    if (value <= 0.04045F) return value / 12.92F;
    else if (value < 1.0F) return pow((value + 0.055F) / 1.055F, 2.4F);
    else return pow(value, 2.2F);
}
inline half3 GammaToLinearSpace(half3 sRGB)
{
    return sRGB * (sRGB * (sRGB * 0.305306011h + 0.682171111h) + 0.012522878h);
}
inline half3 LinearToGammaSpace(half3 linRGB)
{
    linRGB = max(linRGB, half3(0.h, 0.h, 0.h));
    return max(1.055h * pow(linRGB, 0.416666667h) - 0.055h, 0.h);
}

// lines 179-198
inline float3 UnityObjectToWorldNormal(in float3 norm)
{
    return normalize(mul(norm, (float3x3)unity_WorldToObject));
}
inline float3 UnityWorldSpaceLightDir(in float3 worldPos)
{
    return _WorldSpaceLightPos0.xyz - worldPos * _WorldSpaceLightPos0.w;
}

#define TRANSFORM_TEX(tex, name) (tex.xy * name##_ST.xy + name##_ST.zw)

// lines 904-994: shadow casters (normal offset; point-light cube shadows store the distance)
float4 UnityClipSpaceShadowCasterPos(float4 vertex, float3 normal)
{
    float4 wPos = mul(unity_ObjectToWorld, vertex);
    if (unity_LightShadowBias.z != 0.0)
    {
        float3 wNormal = UnityObjectToWorldNormal(normal);
        float3 wLight = normalize(UnityWorldSpaceLightDir(wPos.xyz));
        float shadowCos = dot(wNormal, wLight);
        float shadowSine = sqrt(1 - shadowCos * shadowCos);
        wPos.xyz -= wNormal * (unity_LightShadowBias.z * shadowSine);
    }
    return mul(UNITY_MATRIX_VP, wPos);
}
float4 UnityApplyLinearShadowBias(float4 clipPos)
{
#if defined(UNITY_REVERSED_Z)
    clipPos.z += max(-1, min(unity_LightShadowBias.x / clipPos.w, 0));
    float clamped = min(clipPos.z, clipPos.w * UNITY_NEAR_CLIP_VALUE);
#else
    clipPos.z += saturate(unity_LightShadowBias.x / clipPos.w);
    float clamped = max(clipPos.z, clipPos.w * UNITY_NEAR_CLIP_VALUE);
#endif
    clipPos.z = lerp(clipPos.z, clamped, unity_LightShadowBias.y);
    return clipPos;
}
#if defined(SHADOWS_CUBE) && !defined(SHADOWS_CUBE_IN_DEPTH_TEX)
    #define V2F_SHADOW_CASTER_NOPOS float3 vec : TEXCOORD0;
    #define TRANSFER_SHADOW_CASTER_NOPOS(o, opos) o.vec = mul(unity_ObjectToWorld, v.vertex).xyz - _LightPositionRange.xyz; opos = UnityObjectToClipPos(v.vertex);
    #define SHADOW_CASTER_FRAGMENT(i) return (length(i.vec) + unity_LightShadowBias.x) * _LightPositionRange.w;
#else
    #define V2F_SHADOW_CASTER_NOPOS
    #define TRANSFER_SHADOW_CASTER_NOPOS(o, opos) opos = UnityClipSpaceShadowCasterPos(v.vertex, v.normal); opos = UnityApplyLinearShadowBias(opos);
    #define SHADOW_CASTER_FRAGMENT(i) return 0;
#endif
#define V2F_SHADOW_CASTER V2F_SHADOW_CASTER_NOPOS UNITY_POSITION(pos)
#define TRANSFER_SHADOW_CASTER_NORMALOFFSET(o) TRANSFER_SHADOW_CASTER_NOPOS(o, o.pos)

#endif // UNITY_CG_INCLUDED
