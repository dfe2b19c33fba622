// STAND-IN FOR Unity's CGIncludes/UnityLightingCommon.cginc -- NOT UNITY'S FILE.
#ifndef UNITY_LIGHTING_COMMON_INCLUDED
#define UNITY_LIGHTING_COMMON_INCLUDED
fixed4 _LightColor0;   // the main light's colour × intensity in the forward base pass
#endif
