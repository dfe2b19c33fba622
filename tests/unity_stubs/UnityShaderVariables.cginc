// STAND-IN FOR Unity's CGIncludes/UnityShaderVariables.cginc -- NOT UNITY'S FILE.
// The built-in variables the package's shaders use, in Unity's cbuffers (same names and member
// order, so that a layout check sees what Unity's compiler sees), and Unity's stereo redefinitions
// (2022.3 lines 12-33, 166-199): with any stereo path the view matrices become per-eye arrays
// indexed by unity_StereoEyeIndex, which only the stereo macros of UnityInstancing.cginc set.
#ifndef UNITY_SHADER_VARIABLES_INCLUDED
#define UNITY_SHADER_VARIABLES_INCLUDED

#include "HLSLSupport.cginc"

#if defined(UNITY_SINGLE_PASS_STEREO) || defined(UNITY_STEREO_INSTANCING_ENABLED) || defined(UNITY_STEREO_MULTIVIEW_ENABLED)
    #define USING_STEREO_MATRICES
#endif

#if defined(USING_STEREO_MATRICES)
    #define glstate_matrix_projection unity_StereoMatrixP[unity_StereoEyeIndex]
    #define unity_MatrixV unity_StereoMatrixV[unity_StereoEyeIndex]
    #define unity_MatrixInvV unity_StereoMatrixInvV[unity_StereoEyeIndex]
    #define unity_MatrixVP unity_StereoMatrixVP[unity_StereoEyeIndex]
    #define _WorldSpaceCameraPos unity_StereoWorldSpaceCameraPos[unity_StereoEyeIndex]
#endif

#define UNITY_MATRIX_P glstate_matrix_projection
#define UNITY_MATRIX_V unity_MatrixV
#define UNITY_MATRIX_I_V unity_MatrixInvV
#define UNITY_MATRIX_VP unity_MatrixVP
#define UNITY_MATRIX_M unity_ObjectToWorld

CBUFFER_START(UnityPerCamera)
    float4 _Time;
#if !defined(USING_STEREO_MATRICES)
    float3 _WorldSpaceCameraPos;
#endif
    float4 _ProjectionParams;
CBUFFER_END

CBUFFER_START(UnityLighting)
    float4 _WorldSpaceLightPos0;     // directional light: direction toward the light, w = 0
    float4 _LightPositionRange;
CBUFFER_END

CBUFFER_START(UnityShadows)
    float4 unity_LightShadowBias;
CBUFFER_END

// The per-draw block the SRP Batcher recognises (URP's UnityInput.hlsl starts its UnityPerDraw alike).
CBUFFER_START(UnityPerDraw)
    float4x4 unity_ObjectToWorld;
    float4x4 unity_WorldToObject;
    float4 unity_LODFade;
    float4 unity_WorldTransformParams;
    float4 unity_RenderingLayer;
CBUFFER_END

#if defined(USING_STEREO_MATRICES)
GLOBAL_CBUFFER_START(UnityStereoGlobals)
    float4x4 unity_StereoMatrixP[2];
    float4x4 unity_StereoMatrixV[2];
    float4x4 unity_StereoMatrixInvV[2];
    float4x4 unity_StereoMatrixVP[2];
    float3 unity_StereoWorldSpaceCameraPos[2];
GLOBAL_CBUFFER_END
#endif

// Where the eye index comes from: the view ID (multiview, vertex stage), a static set by the
// stereo macros (stereo instancing, and multiview fragments), or a cbuffer (single-pass stereo).
#if defined(UNITY_STEREO_MULTIVIEW_ENABLED) && defined(SHADER_STAGE_VERTEX)
    #define unity_StereoEyeIndex UNITY_VIEWID
    UNITY_DECLARE_MULTIVIEW(2);
#elif defined(UNITY_STEREO_INSTANCING_ENABLED) || defined(UNITY_STEREO_MULTIVIEW_ENABLED)
    static uint unity_StereoEyeIndex;
#elif defined(UNITY_SINGLE_PASS_STEREO)
    GLOBAL_CBUFFER_START(UnityStereoEyeIndex)
        int unity_StereoEyeIndex;
    GLOBAL_CBUFFER_END
#endif

CBUFFER_START(UnityPerFrame)
    float4 glstate_lightmodel_ambient;
#if !defined(USING_STEREO_MATRICES)
    float4x4 glstate_matrix_projection;
    float4x4 unity_MatrixV;
    float4x4 unity_MatrixInvV;
    float4x4 unity_MatrixVP;
    int unity_StereoEyeIndex;
#endif
CBUFFER_END

#endif // UNITY_SHADER_VARIABLES_INCLUDED
