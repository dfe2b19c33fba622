// The passes of Shlight/SH9 Diffuse (SH9Diffuse.shader), for the built-in pipeline and URP.
//
// Written on Unity's built-in CGIncludes only (UnityCG.cginc; Unity puts HLSLSupport.cginc and
// UnityShaderVariables.cginc in front of every CGPROGRAM), so that the shader compiles in projects
// without URP; the few URP globals used are declared here by name, as URP's ShaderLibrary declares
// them. Define SH9_URP before including for the URP SubShader.
//
// Single-pass instanced / multiview stereo: every pass declares UNITY_VERTEX_INPUT_INSTANCE_ID and
// UNITY_VERTEX_OUTPUT_STEREO, calls UNITY_SETUP_INSTANCE_ID and UNITY_INITIALIZE_VERTEX_OUTPUT_STEREO
// in the vertex stage and UNITY_SETUP_STEREO_EYE_INDEX_POST_VERTEX in the fragment stage
// (UnityInstancing.cginc).
#ifndef SH9_DIFFUSE_PASSES_INCLUDED
#define SH9_DIFFUSE_PASSES_INCLUDED

#include "UnityCG.cginc"
#include "sh9_irradiance.hlsl"

// Texture and sampler state declared separately on D3D11/GL/Vulkan/Metal (HLSLSupport.cginc's
// UNITY_DECLARE_TEX2D), a DX9-style sampler2D elsewhere.
UNITY_DECLARE_TEX2D(_MainTex);

// SRP Batcher: every material property in one cbuffer named UnityPerMaterial, with the same layout
// in every pass and variant. With GPU instancing, _Color is per instance (MaterialPropertyBlock
// colours stay distinct when renderers are drawn together) and a placeholder of the same size keeps
// its slot, the pattern of MRTK3 Graphics Tools (GraphicsToolsStandardInput.hlsl lines 177-183, 292-297).
CBUFFER_START(UnityPerMaterial)
    float4 _MainTex_ST;
#if defined(UNITY_INSTANCING_ENABLED)
    float4 _ColorPerInstanceSlot;
#else
    float4 _Color;
#endif
    float _Exposure;
CBUFFER_END

#if defined(UNITY_INSTANCING_ENABLED)
UNITY_INSTANCING_BUFFER_START(SH9PerInstance)
    UNITY_DEFINE_INSTANCED_PROP(float4, _Color)
UNITY_INSTANCING_BUFFER_END(SH9PerInstance)
#endif

// 1 while SH9LightingClient shows the server's first light on a Directional Light (the SH9 then
// holds the rest of the room): add the main light. 0 otherwise, so that a scene's own default light
// does not add to a room that the SH9 already carries in full.
float _SHMainLightScale;

#if defined(SH9_URP)
    // URP ShaderLibrary/Input.hlsl: direction toward the main light (w = 0 for a directional light)
    // and its colour × intensity as URP's shaders see it.
    float4 _MainLightPosition;
    half4 _MainLightColor;
    #define SH9_MAIN_LIGHT_DIRECTION _MainLightPosition.xyz
    #define SH9_MAIN_LIGHT_COLOR _MainLightColor.rgb
#else
    // Built-in forward base pass: the main directional light (UnityShaderVariables.cginc,
    // UnityLightingCommon.cginc), as in the Unity manual's "simple diffuse lighting" example.
    #include "UnityLightingCommon.cginc"
    #define SH9_MAIN_LIGHT_DIRECTION _WorldSpaceLightPos0.xyz
    #define SH9_MAIN_LIGHT_COLOR _LightColor0.rgb
#endif

// ---- passthrough: the hologram as the headset's camera shows its real replica -------------------
// SH9_PASSTHROUGH (SH9LightingClient, Exposure Mode Passthrough; docs/contract.md §15, "The display lookup"):
// the linear colour × the view's exposure · white balance (_SHPassthroughGain) is the camera's sensor exposure
// X; the 256-entry lookup _SHPassthroughLut, indexed by t = (log2 X − lo) / (hi − lo) (_SHPassthroughRange:
// lo, 1 / (hi − lo), 2^−lo), gives the code g⁻¹(X) / 255 the passthrough image shows, an sRGB-encoded display
// value; below the first entry (X < 2^lo) linear in X down to code 0.
#if defined(SH9_PASSTHROUGH)
UNITY_DECLARE_TEX2D(_SHPassthroughLut);
float4 _SHPassthroughGain;
float4 _SHPassthroughRange;

float3 SH9PassthroughDisplay(float3 linearColour)
{
    float3 x = max(linearColour * _SHPassthroughGain.rgb, 1e-30);
    float3 t = saturate((log2(x) - _SHPassthroughRange.x) * _SHPassthroughRange.y);
    // texel centres: entry j at u = (j + 0.5) / 256, so t = 0 and 1 hit the first and last entries (no mips:
    // the client makes the lookup a bilinear, clamped 256 × 1 texture)
    float3 u = (t * 255.0 + 0.5) / 256.0;
    float3 entry = float3(UNITY_SAMPLE_TEX2D(_SHPassthroughLut, float2(u.r, 0.5)).r,
                          UNITY_SAMPLE_TEX2D(_SHPassthroughLut, float2(u.g, 0.5)).g,
                          UNITY_SAMPLE_TEX2D(_SHPassthroughLut, float2(u.b, 0.5)).b);
    // the toe: below 2^lo, t = 0 reads entry 0, scaled by X / 2^lo (1 from 2^lo up)
    return entry * min(x * _SHPassthroughRange.z, 1.0);
}
#endif

// ---- forward: albedo × (E(n)/π + main light × N·L) --------------------------------------------

struct SH9Attributes
{
    float4 vertex : POSITION;
    float3 normal : NORMAL;
    float2 uv : TEXCOORD0;
    UNITY_VERTEX_INPUT_INSTANCE_ID
};

struct SH9Varyings
{
    float4 pos : SV_POSITION;
    float2 uv : TEXCOORD0;
    float3 worldNormal : TEXCOORD1;
    float4 color : COLOR0;
    UNITY_VERTEX_OUTPUT_STEREO
};

SH9Varyings SH9ForwardVertex(SH9Attributes v)
{
    SH9Varyings o;
    UNITY_SETUP_INSTANCE_ID(v);
    UNITY_INITIALIZE_OUTPUT(SH9Varyings, o);
    UNITY_INITIALIZE_VERTEX_OUTPUT_STEREO(o);
    o.pos = UnityObjectToClipPos(v.vertex);
    o.uv = TRANSFORM_TEX(v.uv, _MainTex);
    o.worldNormal = UnityObjectToWorldNormal(v.normal); // Unity world frame, like the SH9 matrices
    o.color = UNITY_ACCESS_INSTANCED_PROP(SH9PerInstance, _Color); // read once per vertex
    return o;
}

half4 SH9ForwardFragment(SH9Varyings i) : SV_Target
{
    UNITY_SETUP_STEREO_EYE_INDEX_POST_VERTEX(i);
    float3 n = normalize(i.worldNormal);
    float4 albedo = UNITY_SAMPLE_TEX2D(_MainTex, i.uv) * i.color;
    float3 lightColor = SH9_MAIN_LIGHT_COLOR;
#ifdef UNITY_COLORSPACE_GAMMA
    // Gamma project: light in linear, encode at the end. SH9LightingClient sets the light's colour
    // × intensity to the sRGB encoding of E/π here, so decode it exactly.
    albedo.rgb = GammaToLinearSpace(albedo.rgb);
    lightColor = float3(GammaToLinearSpaceExact(lightColor.r), GammaToLinearSpaceExact(lightColor.g),
                        GammaToLinearSpaceExact(lightColor.b));
#endif
    // Lambert: radiance = ρ E / π (docs/contract.md §2); E is clamped at 0 in SHIrradiance. A Unity light's
    // colour is already E/π of its light (Unity's Lambert has no 1/π): added as is.
    float3 irradianceOverPi = SHIrradiance(n) / UNITY_PI +
                              _SHMainLightScale * lightColor * max(0.0, dot(n, SH9_MAIN_LIGHT_DIRECTION));
    float3 radiance = albedo.rgb * irradianceOverPi * _Exposure;
#if defined(SH9_PASSTHROUGH)
    // the display value itself: a gamma project writes it as is; a linear one writes its sRGB decoding,
    // which the sRGB framebuffer encodes back to it
    float3 display = SH9PassthroughDisplay(radiance);
    #ifdef UNITY_COLORSPACE_GAMMA
    radiance = display;
    #else
    radiance = float3(GammaToLinearSpaceExact(display.r), GammaToLinearSpaceExact(display.g),
                      GammaToLinearSpaceExact(display.b));
    #endif
#elif defined(UNITY_COLORSPACE_GAMMA)
    radiance = LinearToGammaSpace(radiance);
#endif
    return half4(radiance, albedo.a);
}

// ---- shadow caster ------------------------------------------------------------------------------

struct SH9ShadowAttributes
{
    float4 vertex : POSITION;
    float3 normal : NORMAL;
    UNITY_VERTEX_INPUT_INSTANCE_ID
};

#if defined(SH9_URP)

// URP sets these for its shadow pass (ShadowCasterPass.hlsl, Shadows.hlsl): x depth bias, y normal
// bias; the direction toward a directional light, or the position of a punctual one.
float4 _ShadowBias;
float3 _LightDirection;
float3 _LightPosition;

struct SH9ShadowVaryings
{
    float4 pos : SV_POSITION;
    UNITY_VERTEX_OUTPUT_STEREO
};

SH9ShadowVaryings SH9ShadowVertex(SH9ShadowAttributes v)
{
    SH9ShadowVaryings o;
    UNITY_SETUP_INSTANCE_ID(v);
    UNITY_INITIALIZE_OUTPUT(SH9ShadowVaryings, o);
    UNITY_INITIALIZE_VERTEX_OUTPUT_STEREO(o);
    float3 positionWS = mul(unity_ObjectToWorld, float4(v.vertex.xyz, 1.0)).xyz;
    float3 normalWS = UnityObjectToWorldNormal(v.normal);
#if defined(_CASTING_PUNCTUAL_LIGHT_SHADOW)
    float3 lightDirectionWS = normalize(_LightPosition - positionWS);
#else
    float3 lightDirectionWS = _LightDirection;
#endif
    // URP's ApplyShadowBias (Shadows.hlsl): depth bias along the light, normal bias (negative) inward
    float scale = (1.0 - saturate(dot(lightDirectionWS, normalWS))) * _ShadowBias.y;
    positionWS = lightDirectionWS * _ShadowBias.xxx + positionWS;
    positionWS = normalWS * scale.xxx + positionWS;
    o.pos = mul(UNITY_MATRIX_VP, float4(positionWS, 1.0));
    // clamp to the near plane, as URP's GetShadowPositionHClip does (ShadowCasterPass.hlsl)
#if defined(UNITY_REVERSED_Z)
    o.pos.z = min(o.pos.z, UNITY_NEAR_CLIP_VALUE);
#else
    o.pos.z = max(o.pos.z, UNITY_NEAR_CLIP_VALUE);
#endif
    return o;
}

half4 SH9ShadowFragment(SH9ShadowVaryings i) : SV_Target
{
    UNITY_SETUP_STEREO_EYE_INDEX_POST_VERTEX(i);
    return 0;
}

#else

// Built-in: UnityCG.cginc's shadow-caster macros (normal offset bias, point-light cube shadows).
struct SH9ShadowVaryings
{
    V2F_SHADOW_CASTER;
    UNITY_VERTEX_OUTPUT_STEREO
};

SH9ShadowVaryings SH9ShadowVertex(SH9ShadowAttributes v)
{
    SH9ShadowVaryings o;
    UNITY_SETUP_INSTANCE_ID(v);
    UNITY_INITIALIZE_OUTPUT(SH9ShadowVaryings, o);
    UNITY_INITIALIZE_VERTEX_OUTPUT_STEREO(o);
    TRANSFER_SHADOW_CASTER_NORMALOFFSET(o)
    return o;
}

float4 SH9ShadowFragment(SH9ShadowVaryings i) : SV_Target
{
    UNITY_SETUP_STEREO_EYE_INDEX_POST_VERTEX(i);
    SHADOW_CASTER_FRAGMENT(i)
}

#endif

// ---- URP depth prepass and normals prepass ---------------------------------------------------------
// With URP 12+ depth priming (Auto/Forced) opaque objects are drawn in the colour pass only where the
// prepass left their depth: a shader without DepthOnly does not appear at all (the reason for these).

struct SH9DepthAttributes
{
    float4 vertex : POSITION;
    float3 normal : NORMAL;
    UNITY_VERTEX_INPUT_INSTANCE_ID
};

struct SH9DepthVaryings
{
    float4 pos : SV_POSITION;
    UNITY_VERTEX_OUTPUT_STEREO
};

SH9DepthVaryings SH9DepthOnlyVertex(SH9DepthAttributes v)
{
    SH9DepthVaryings o;
    UNITY_SETUP_INSTANCE_ID(v);
    UNITY_INITIALIZE_OUTPUT(SH9DepthVaryings, o);
    UNITY_INITIALIZE_VERTEX_OUTPUT_STEREO(o);
    o.pos = UnityObjectToClipPos(v.vertex);
    return o;
}

// The depth also goes to the red channel, for URP versions that copy depth through a colour target
// (DepthOnlyPass.hlsl returns input.positionCS.z with ColorMask R).
half SH9DepthOnlyFragment(SH9DepthVaryings i) : SV_Target
{
    UNITY_SETUP_STEREO_EYE_INDEX_POST_VERTEX(i);
    return i.pos.z;
}

struct SH9DepthNormalsVaryings
{
    float4 pos : SV_POSITION;
    float3 normalWS : TEXCOORD1;
    UNITY_VERTEX_OUTPUT_STEREO
};

SH9DepthNormalsVaryings SH9DepthNormalsVertex(SH9DepthAttributes v)
{
    SH9DepthNormalsVaryings o;
    UNITY_SETUP_INSTANCE_ID(v);
    UNITY_INITIALIZE_OUTPUT(SH9DepthNormalsVaryings, o);
    UNITY_INITIALIZE_VERTEX_OUTPUT_STEREO(o);
    o.pos = UnityObjectToClipPos(v.vertex);
    o.normalWS = UnityObjectToWorldNormal(v.normal);
    return o;
}

// What URP's passes write into _CameraNormalsTexture (the encodings of core's Packing.hlsl):
// URP 12+ (Unity 2021.2+): world-space normals, octahedron-encoded in 8:8:8 with _GBUFFER_NORMALS_OCT
// (UnlitDepthNormalsPass.hlsl); URP 10/11: view-space normals, PackNormalOctRectEncode in xy.
float4 SH9DepthNormalsFragment(SH9DepthNormalsVaryings i) : SV_Target
{
    UNITY_SETUP_STEREO_EYE_INDEX_POST_VERTEX(i);
    float3 n = normalize(i.normalWS);
#if UNITY_VERSION >= 202120
    #if defined(_GBUFFER_NORMALS_OCT)
        // PackNormalOctQuadEncode, remapped to [0, 1], then PackFloat2To888
        n /= max(dot(abs(n), 1.0), 1e-6);
        float t = saturate(-n.z);
        float2 oct = n.xy + float2(n.x >= 0.0 ? t : -t, n.y >= 0.0 ? t : -t);
        float2 remapped = saturate(oct * 0.5 + 0.5);
        uint2 bits = (uint2)(remapped * 4095.5);
        uint2 hi = bits >> 8;
        uint2 lo = bits & 255;
        return float4(float3(uint3(lo, hi.x | (hi.y << 4))) / 255.0, 0.0);
    #else
        return float4(n, 0.0);
    #endif
#else
    // PackNormalOctRectEncode(TransformWorldToViewDir(n, true))
    float3 nv = normalize(mul((float3x3)UNITY_MATRIX_V, n));
    float3 p = nv / dot(abs(nv), 1.0);
    float r = saturate(0.5 - 0.5 * p.x + 0.5 * p.y);
    float g = p.x + p.y;
    return float4(p.z >= 0.0 ? r : -r, g, 0.0, 0.0);
#endif
}

#endif // SH9_DIFFUSE_PASSES_INCLUDED
