// STAND-IN FOR Unity's CGIncludes/HLSLSupport.cginc -- NOT UNITY'S FILE.
// Written for tests/clients/unity/test_unity_shaders.py from a reading of Unity's built-in shader includes
// (2020.3, 2022.3 and 6000.0): only what the package's shaders reach, with Unity's semantics. The
// test harness puts it (and UnityShaderVariables.cginc) in front of every CGPROGRAM, as Unity does.
#ifndef HLSL_SUPPORT_INCLUDED
#define HLSL_SUPPORT_INCLUDED

#if defined(SHADER_API_GLCORE) || defined(SHADER_API_GLES3) || defined(SHADER_API_METAL) || defined(SHADER_API_VULKAN)
    #define UNITY_COMPILER_HLSL
    #define UNITY_COMPILER_HLSLCC
#elif defined(SHADER_API_D3D11)
    #define UNITY_COMPILER_HLSL
#endif

// Stereo paths (HLSLSupport.cginc lines 24-30 in 2022.3): multiview only on GL/Vulkan, stereo
// instancing on D3D11, GL, Vulkan and Metal. On other APIs the keyword does nothing.
#if defined(STEREO_MULTIVIEW_ON) && (defined(SHADER_API_GLES3) || defined(SHADER_API_GLCORE) || defined(SHADER_API_VULKAN))
    #define UNITY_STEREO_MULTIVIEW_ENABLED
#endif
#if (defined(SHADER_API_D3D11) || defined(SHADER_API_GLCORE) || defined(SHADER_API_GLES3) || defined(SHADER_API_VULKAN) || defined(SHADER_API_METAL)) && defined(STEREO_INSTANCING_ON)
    #define UNITY_STEREO_INSTANCING_ENABLED
#endif

// Precision types: D3D11 and Vulkan map half to min16float (lines 218-273).
#define half min16float
#define half2 min16float2
#define half3 min16float3
#define half4 min16float4
#define fixed float
#define fixed2 float2
#define fixed3 float3
#define fixed4 float4

// Constant buffers are real only on D3D11 (and with UNITY_ENABLE_CBUFFER); elsewhere their members
// are plain globals (lines 352-358). Stereo globals are real cbuffers with multiview, or with SPS or
// stereo instancing on GL/Metal (lines 360-366).
#if defined(SHADER_API_D3D11) || defined(UNITY_ENABLE_CBUFFER)
    #define CBUFFER_START(name) cbuffer name {
    #define CBUFFER_END };
#else
    #define CBUFFER_START(name)
    #define CBUFFER_END
#endif
#if defined(UNITY_STEREO_MULTIVIEW_ENABLED) || ((defined(UNITY_SINGLE_PASS_STEREO) || defined(UNITY_STEREO_INSTANCING_ENABLED)) && (defined(SHADER_API_GLCORE) || defined(SHADER_API_GLES3) || defined(SHADER_API_METAL)))
    #define GLOBAL_CBUFFER_START(name) cbuffer name {
    #define GLOBAL_CBUFFER_END }
#else
    #define GLOBAL_CBUFFER_START(name) CBUFFER_START(name)
    #define GLOBAL_CBUFFER_END CBUFFER_END
#endif

// OVR_multiview: the view index reaches the vertex stage through a pseudo cbuffer (lines 368-374).
#if defined(UNITY_STEREO_MULTIVIEW_ENABLED) && defined(SHADER_STAGE_VERTEX)
    #define UNITY_DECLARE_MULTIVIEW(number_of_views) GLOBAL_CBUFFER_START(OVR_multiview) uint gl_ViewID; uint numViews_##number_of_views; GLOBAL_CBUFFER_END
    #define UNITY_VIEWID gl_ViewID
#endif

#define UNITY_POSITION(pos) float4 pos : SV_POSITION

// Textures: separate texture and sampler state with DX11-style syntax (lines 448-470), DX9 style
// otherwise (lines 545-565).
#if defined(SHADER_API_D3D11) || defined(UNITY_COMPILER_HLSLCC)
    #define UNITY_DECLARE_TEX2D(tex) Texture2D tex; SamplerState sampler##tex
    #define UNITY_SAMPLE_TEX2D(tex, coord) tex.Sample(sampler##tex, coord)
#else
    #define UNITY_DECLARE_TEX2D(tex) sampler2D tex
    #define UNITY_SAMPLE_TEX2D(tex, coord) tex2D(tex, coord)
#endif

// D3D-style clip space z in [0, 1], reversed (lines 670-678).
#if defined(SHADER_API_D3D11) || defined(SHADER_API_METAL) || defined(SHADER_API_VULKAN)
    #define UNITY_REVERSED_Z 1
#endif
#if defined(UNITY_REVERSED_Z)
    #define UNITY_NEAR_CLIP_VALUE (1.0)
#else
    #define UNITY_NEAR_CLIP_VALUE (-1.0)
#endif

#if defined(UNITY_COMPILER_HLSL) || defined(UNITY_COMPILER_HLSLCC)
    #define UNITY_INITIALIZE_OUTPUT(type, name) name = (type)0;
#else
    #define UNITY_INITIALIZE_OUTPUT(type, name)
#endif

#endif // HLSL_SUPPORT_INCLUDED
