// Shadow catcher for the built-in pipeline (issue 30; docs/shadows_consumers.md): invisible except for
// the darkening. Put it on a stand-in for the real floor (a plane where the floor is); it multiplies what
// is behind it by SHShadowRatioOfSphere (sh9_lights.hlsl): the room's irradiance with the key light blocked
// by V (Unity's shadow attenuation of the main directional light, which SH9LightingClient drives from the
// key light with Key Light Shadows on) over the irradiance with it unblocked; with an SH9ShadowOccluder on
// the hologram, lights 1..3 blocked by its bounding sphere (each light's disc, SHSphereLightVisibility), the
// key light too where it casts no shadow map, and the ambient the sphere hides taken off.
//
// How the darkening reaches the eye, set by the material's blend factors:
//   * Multiply (SH9 Shadow Catcher Multiply.mat): Blend DstColor Zero on colour, alpha kept: for video
//     see-through where the camera image is in the framebuffer (AR Foundation's camera background;
//     Android XR / Quest apps that draw the passthrough camera texture themselves). Per colour.
//   * Passthrough alpha (SH9 Shadow Catcher Passthrough.mat): black at coverage 1 − ratio (Blend Zero
//     OneMinusSrcAlpha on colour, One OneMinusSrcAlpha on alpha): for a compositor that shows the
//     passthrough layer through the eye buffer's alpha (Quest passthrough as an underlay), which then
//     shows passthrough × ratio (Rec. 709 luminance of the ratio: one alpha per pixel).
// Additive displays (HoloLens) cannot darken: black is transparent there, so the catcher shows nothing.
// Drawn after opaque geometry (Geometry+10), no depth write, not a shadow caster (Fallback Off).
Shader "Shlight/SH9 Shadow Catcher"
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
        Tags { "Queue" = "Geometry+10" "RenderType" = "Transparent" "IgnoreProjector" = "True" }
        LOD 100

        Pass
        {
            Name "SH9ShadowCatcher"
            Tags { "LightMode" = "ForwardBase" }
            Blend [_SrcBlend] [_DstBlend], [_SrcBlendAlpha] [_DstBlendAlpha]
            ZWrite Off
            ZTest LEqual
            Cull Back

            CGPROGRAM
            #pragma vertex SH9CatcherVertex
            #pragma fragment SH9CatcherFragment
            #pragma target 3.5
            #pragma multi_compile_instancing
            #pragma multi_compile_fwdbase nolightmap nodynlightmap nodirlightmap novertexlight
            #include "UnityCG.cginc"
            #include "AutoLight.cginc"
            #include "sh9_lights.hlsl"

            float _ShadowStrength;
            // global, from SH9ShadowOccluder: the hologram's bounding sphere in world space (xyz centre, w radius;
            // w <= 0 or never set: no occluder, the ratio is SHShadowRatio's)
            float4 _SHOccluderSphere;

            struct SH9CatcherAttributes
            {
                float4 vertex : POSITION;
                float3 normal : NORMAL;
                UNITY_VERTEX_INPUT_INSTANCE_ID
            };

            struct SH9CatcherVaryings
            {
                float4 pos : SV_POSITION;              // named pos: AutoLight's TRANSFER_SHADOW reads it
                float3 worldPos : TEXCOORD0;
                float3 worldNormal : TEXCOORD1;
                UNITY_SHADOW_COORDS(2)
                UNITY_VERTEX_OUTPUT_STEREO
            };

            SH9CatcherVaryings SH9CatcherVertex(SH9CatcherAttributes v)   // named v: TRANSFER_SHADOW reads v.vertex
            {
                SH9CatcherVaryings o;
                UNITY_SETUP_INSTANCE_ID(v);
                UNITY_INITIALIZE_OUTPUT(SH9CatcherVaryings, o);
                UNITY_INITIALIZE_VERTEX_OUTPUT_STEREO(o);
                o.pos = UnityObjectToClipPos(v.vertex);
                o.worldPos = mul(unity_ObjectToWorld, v.vertex).xyz;
                o.worldNormal = UnityObjectToWorldNormal(v.normal);
                UNITY_TRANSFER_SHADOW(o, float2(0, 0));
                return o;
            }

            float4 SH9CatcherFragment(SH9CatcherVaryings i) : SV_Target
            {
                UNITY_SETUP_STEREO_EYE_INDEX_POST_VERTEX(i);
                // the main directional light's shadow: 0 blocked, 1 open (with the shadow-distance fade)
                UNITY_LIGHT_ATTENUATION(visibility, i, i.worldPos);
                float3 n = normalize(i.worldNormal);
            #if defined(SHADOWS_SCREEN)
                float keyVisibility = visibility;   // the shadow map: the hologram's real shape
            #else
                // no shadow map for the key light: its disc's share left by the occluder sphere (1 without one)
                float keyVisibility = SHSphereLightVisibility(i.worldPos, _SHOccluderSphere, _SHLightDirection[0].xyz,
                                                              _SHLightAngularRadius.x);
            #endif
                // lights 1..3 past the hologram's bounding sphere (set by SH9ShadowOccluder), and the ambient it hides;
                // SH9LightingClient keeps lights 1..3 in the SH9 globals too (folded), which this takes out again
                float3 ratio = SHShadowRatioOfSphere(n, i.worldPos, _SHOccluderSphere, keyVisibility, _ShadowStrength);
                // rgb: the factor (Multiply); a: 1 − its luminance (Passthrough alpha)
                return float4(ratio, 1.0 - dot(ratio, float3(0.2126, 0.7152, 0.0722)));
            }
            ENDCG
        }
    }
    Fallback Off
}
