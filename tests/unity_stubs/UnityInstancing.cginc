// STAND-IN FOR Unity's CGIncludes/UnityInstancing.cginc -- NOT UNITY'S FILE.
// The instancing and stereo macros with Unity's definitions (2022.3 lines 16-215, 217-329,
// 331-340; 6000.0 is the same): with INSTANCING_ON the instance ID is a vertex input and per-draw
// matrices come from per-instance arrays; with STEREO_INSTANCING_ON the eye is the low bit of the
// instance ID and the vertex stage writes it to SV_RenderTargetArrayIndex; with multiview the eye
// travels to the fragment stage in BLENDINDICES0. So a shader that forgets
// UNITY_VERTEX_OUTPUT_STEREO or UNITY_VERTEX_INPUT_INSTANCE_ID fails to compile in those variants,
// as it does in Unity, and one that forgets UNITY_SETUP_INSTANCE_ID renders both eyes into one.
#ifndef UNITY_INSTANCING_INCLUDED
#define UNITY_INSTANCING_INCLUDED

#if SHADER_TARGET >= 35 && (defined(SHADER_API_D3D11) || defined(SHADER_API_GLES3) || defined(SHADER_API_GLCORE) || defined(SHADER_API_VULKAN) || defined(SHADER_API_METAL))
    #define UNITY_SUPPORT_INSTANCING
#endif
#if defined(UNITY_SUPPORT_INSTANCING) && defined(INSTANCING_ON)
    #define UNITY_INSTANCING_ENABLED
#endif

#if defined(SHADER_API_GLES3) || defined(SHADER_API_GLCORE) || defined(SHADER_API_METAL) || defined(SHADER_API_VULKAN)
    #define UNITY_INSTANCING_CBUFFER_SCOPE_BEGIN(name) cbuffer name {
    #define UNITY_INSTANCING_CBUFFER_SCOPE_END }
#else
    #define UNITY_INSTANCING_CBUFFER_SCOPE_BEGIN(name) CBUFFER_START(name)
    #define UNITY_INSTANCING_CBUFFER_SCOPE_END CBUFFER_END
#endif

// ---- instance ID ----
#if defined(UNITY_INSTANCING_ENABLED) || defined(UNITY_STEREO_INSTANCING_ENABLED)
    static uint unity_InstanceID;
    UNITY_INSTANCING_CBUFFER_SCOPE_BEGIN(UnityDrawCallInfo)
        int unity_BaseInstanceID;
        int unity_InstanceCount;
    UNITY_INSTANCING_CBUFFER_SCOPE_END
    #define DEFAULT_UNITY_VERTEX_INPUT_INSTANCE_ID uint instanceID : SV_InstanceID;
    #define UNITY_GET_INSTANCE_ID(input) input.instanceID
#else
    #define DEFAULT_UNITY_VERTEX_INPUT_INSTANCE_ID
#endif
#if !defined(UNITY_VERTEX_INPUT_INSTANCE_ID)
    #define UNITY_VERTEX_INPUT_INSTANCE_ID DEFAULT_UNITY_VERTEX_INPUT_INSTANCE_ID
#endif

// ---- stereo target eye ----
#ifdef UNITY_STEREO_INSTANCING_ENABLED
    #define DEFAULT_UNITY_VERTEX_OUTPUT_STEREO uint stereoTargetEyeIndex : SV_RenderTargetArrayIndex;
    #define DEFAULT_UNITY_INITIALIZE_VERTEX_OUTPUT_STEREO(output) output.stereoTargetEyeIndex = unity_StereoEyeIndex
    #define DEFAULT_UNITY_TRANSFER_VERTEX_OUTPUT_STEREO(input, output) output.stereoTargetEyeIndex = input.stereoTargetEyeIndex;
    #define DEFAULT_UNITY_SETUP_STEREO_EYE_INDEX_POST_VERTEX(input) unity_StereoEyeIndex = input.stereoTargetEyeIndex;
#elif defined(UNITY_STEREO_MULTIVIEW_ENABLED)
    #define DEFAULT_UNITY_VERTEX_OUTPUT_STEREO uint stereoTargetEyeIndex : BLENDINDICES0;
    #define DEFAULT_UNITY_INITIALIZE_VERTEX_OUTPUT_STEREO(output) output.stereoTargetEyeIndex = unity_StereoEyeIndex;
    #define DEFAULT_UNITY_TRANSFER_VERTEX_OUTPUT_STEREO(input, output) output.stereoTargetEyeIndex = input.stereoTargetEyeIndex;
    #if defined(SHADER_STAGE_VERTEX)
        #define DEFAULT_UNITY_SETUP_STEREO_EYE_INDEX_POST_VERTEX(input)
    #else
        #define DEFAULT_UNITY_SETUP_STEREO_EYE_INDEX_POST_VERTEX(input) unity_StereoEyeIndex.x = input.stereoTargetEyeIndex;
    #endif
#else
    #define DEFAULT_UNITY_VERTEX_OUTPUT_STEREO
    #define DEFAULT_UNITY_INITIALIZE_VERTEX_OUTPUT_STEREO(output)
    #define DEFAULT_UNITY_TRANSFER_VERTEX_OUTPUT_STEREO(input, output)
    #define DEFAULT_UNITY_SETUP_STEREO_EYE_INDEX_POST_VERTEX(input)
#endif
#if !defined(UNITY_VERTEX_OUTPUT_STEREO)
    #define UNITY_VERTEX_OUTPUT_STEREO DEFAULT_UNITY_VERTEX_OUTPUT_STEREO
#endif
#if !defined(UNITY_INITIALIZE_VERTEX_OUTPUT_STEREO)
    #define UNITY_INITIALIZE_VERTEX_OUTPUT_STEREO(output) DEFAULT_UNITY_INITIALIZE_VERTEX_OUTPUT_STEREO(output)
#endif
#if !defined(UNITY_TRANSFER_VERTEX_OUTPUT_STEREO)
    #define UNITY_TRANSFER_VERTEX_OUTPUT_STEREO(input, output) DEFAULT_UNITY_TRANSFER_VERTEX_OUTPUT_STEREO(input, output)
#endif
#if !defined(UNITY_SETUP_STEREO_EYE_INDEX_POST_VERTEX)
    #define UNITY_SETUP_STEREO_EYE_INDEX_POST_VERTEX(input) DEFAULT_UNITY_SETUP_STEREO_EYE_INDEX_POST_VERTEX(input)
#endif

// ---- UNITY_SETUP_INSTANCE_ID: the global instance ID, and with stereo instancing the eye ----
#if defined(UNITY_INSTANCING_ENABLED) || defined(UNITY_STEREO_INSTANCING_ENABLED)
    void UnitySetupInstanceID(uint inputInstanceID)
    {
    #ifdef UNITY_STEREO_INSTANCING_ENABLED
        unity_StereoEyeIndex = inputInstanceID & 0x01;
        unity_InstanceID = unity_BaseInstanceID + (inputInstanceID >> 1);
    #else
        unity_InstanceID = inputInstanceID + unity_BaseInstanceID;
    #endif
    }
    #define DEFAULT_UNITY_SETUP_INSTANCE_ID(input) { UnitySetupInstanceID(UNITY_GET_INSTANCE_ID(input)); }
    #define UNITY_TRANSFER_INSTANCE_ID(input, output) output.instanceID = UNITY_GET_INSTANCE_ID(input)
#else
    #define DEFAULT_UNITY_SETUP_INSTANCE_ID(input)
    #define UNITY_TRANSFER_INSTANCE_ID(input, output)
#endif
#if !defined(UNITY_SETUP_INSTANCE_ID)
    #define UNITY_SETUP_INSTANCE_ID(input) DEFAULT_UNITY_SETUP_INSTANCE_ID(input)
#endif

// ---- per-instance properties ----
#if defined(UNITY_INSTANCING_ENABLED)
    #define UNITY_INSTANCED_ARRAY_SIZE 2 // flexible array size on D3D11/GL/Vulkan/Metal
    #define UNITY_INSTANCING_BUFFER_START(buf) UNITY_INSTANCING_CBUFFER_SCOPE_BEGIN(UnityInstancing_##buf) struct _type_##buf {
    #define UNITY_INSTANCING_BUFFER_END(arr) } arr##Array[UNITY_INSTANCED_ARRAY_SIZE]; UNITY_INSTANCING_CBUFFER_SCOPE_END
    #define UNITY_DEFINE_INSTANCED_PROP(type, var) type var;
    #define UNITY_ACCESS_INSTANCED_PROP(arr, var) arr##Array[unity_InstanceID].var

    UNITY_INSTANCING_BUFFER_START(PerDraw0)
        UNITY_DEFINE_INSTANCED_PROP(float4x4, unity_ObjectToWorldArray)
        UNITY_DEFINE_INSTANCED_PROP(float4x4, unity_WorldToObjectArray)
    UNITY_INSTANCING_BUFFER_END(unity_Builtins0)

    #define unity_ObjectToWorld UNITY_ACCESS_INSTANCED_PROP(unity_Builtins0, unity_ObjectToWorldArray)
    #define unity_WorldToObject UNITY_ACCESS_INSTANCED_PROP(unity_Builtins0, unity_WorldToObjectArray)

    inline float4 UnityObjectToClipPosInstanced(in float3 pos)
    {
        return mul(UNITY_MATRIX_VP, mul(unity_ObjectToWorld, float4(pos, 1.0)));
    }
    inline float4 UnityObjectToClipPosInstanced(float4 pos) { return UnityObjectToClipPosInstanced(pos.xyz); }
    #define UnityObjectToClipPos UnityObjectToClipPosInstanced
#else
    #define UNITY_INSTANCING_BUFFER_START(buf) CBUFFER_START(buf)
    #define UNITY_INSTANCING_BUFFER_END(arr) CBUFFER_END
    #define UNITY_DEFINE_INSTANCED_PROP(type, var) type var;
    #define UNITY_ACCESS_INSTANCED_PROP(arr, var) var
#endif

#endif // UNITY_INSTANCING_INCLUDED
