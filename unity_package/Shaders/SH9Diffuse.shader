// Diffuse (Lambertian) surface lit by the room: radiance = albedo · E(n) / π, with E(n) from
// the three SH9 irradiance matrices that SH9LightingClient sets as globals (sh9_irradiance.hlsl).
//
// * Built-in render pipeline and URP: the pass has no LightMode tag, so the built-in pipeline
//   draws it as an ordinary forward pass and URP draws it as "SRPDefaultUnlit". It needs no
//   Unity light, light probe or lightmap. (Not SRP-Batcher compatible: see the README.)
// * HoloLens single-pass instanced stereo (and multiview): instance ID in, stereo target eye out.
// * Gamma and linear colour space: lighting is computed in linear and encoded at the end.
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
        Tags { "RenderType" = "Opaque" "Queue" = "Geometry" }
        LOD 100

        Pass
        {
            Name "SH9Diffuse"
            ZWrite On
            Cull Back

            CGPROGRAM
            #pragma vertex vert
            #pragma fragment frag
            #pragma target 3.5
            #pragma multi_compile_instancing
            #include "UnityCG.cginc"
            #include "sh9_irradiance.hlsl"

            sampler2D _MainTex;
            float4 _MainTex_ST;
            half4 _Color;
            float _Exposure;

            struct appdata
            {
                float4 vertex : POSITION;
                float3 normal : NORMAL;
                float2 uv : TEXCOORD0;
                UNITY_VERTEX_INPUT_INSTANCE_ID
            };

            struct v2f
            {
                float4 pos : SV_POSITION;
                float2 uv : TEXCOORD0;
                float3 worldNormal : TEXCOORD1;
                UNITY_VERTEX_OUTPUT_STEREO
            };

            v2f vert(appdata v)
            {
                v2f o;
                UNITY_SETUP_INSTANCE_ID(v);
                UNITY_INITIALIZE_OUTPUT(v2f, o);
                UNITY_INITIALIZE_VERTEX_OUTPUT_STEREO(o);
                o.pos = UnityObjectToClipPos(v.vertex);
                o.uv = TRANSFORM_TEX(v.uv, _MainTex);
                o.worldNormal = UnityObjectToWorldNormal(v.normal); // Unity world frame, like the matrices
                return o;
            }

            half4 frag(v2f i) : SV_Target
            {
                UNITY_SETUP_STEREO_EYE_INDEX_POST_VERTEX(i);
                float3 n = normalize(i.worldNormal);
                half4 albedo = tex2D(_MainTex, i.uv) * _Color;
            #ifdef UNITY_COLORSPACE_GAMMA
                albedo.rgb = GammaToLinearSpace(albedo.rgb);
            #endif
                // Lambert: radiance = ρ E / π (DESIGN.md §2); E is clamped at 0 in SHIrradiance.
                float3 radiance = albedo.rgb * SHIrradiance(n) * (_Exposure / UNITY_PI);
            #ifdef UNITY_COLORSPACE_GAMMA
                radiance = LinearToGammaSpace(radiance);
            #endif
                return half4(radiance, albedo.a);
            }
            ENDCG
        }
    }
    FallBack Off
}
