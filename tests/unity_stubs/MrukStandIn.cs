// COMPILE-ONLY STAND-IN FOR Meta's MRUK PassthroughCameraAccess -- NOT MRUK.
//
// The members SH9PassthroughSender uses, declared as MRUK (v81+, namespace Meta.XR) declares them: IsPlaying,
// IsUpdatedThisFrame, Timestamp (DateTime), CurrentResolution, Intrinsics (FocalLength, PrincipalPoint,
// SensorResolution, LensOffset), GetTexture() and GetCameraPose() (the camera's world pose at Timestamp; Unity
// camera axes, looking along +Z). Compiled with -define:SHLIGHT_MRUK. The harness sets the StandIn* fields per
// frame: a simulated headset's image (the stand-in texture carries its JPEG), its pose and intrinsics.
using System;
using UnityEngine;

namespace Meta.XR
{
    public class PassthroughCameraAccess : MonoBehaviour
    {
        public enum CameraPositionType { Left, Right }
        public CameraPositionType CameraPosition;

        public struct CameraIntrinsics
        {
            public Vector2 FocalLength;
            public Vector2 PrincipalPoint;
            public Vector2Int SensorResolution;
            public Pose LensOffset;
        }

        public bool StandInPlaying, StandInUpdatedThisFrame;
        public Pose StandInPose;
        public Texture2D StandInTexture;

        public bool IsPlaying { get { return StandInPlaying; } }
        public bool IsUpdatedThisFrame { get { return StandInUpdatedThisFrame; } }
        public DateTime Timestamp { get; set; }
        public Vector2Int CurrentResolution { get; set; }
        public CameraIntrinsics Intrinsics { get; set; }
        public Texture GetTexture() { return StandInTexture; }
        public Pose GetCameraPose() { return StandInPose; }
    }
}
