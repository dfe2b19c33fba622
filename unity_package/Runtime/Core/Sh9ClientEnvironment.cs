// The reflection cube on the WebSocket (docs/contract.md §12, Transport): with
// Sh9ClientOptions.Environment the subscribe asks for it, and each cube arrives as an
// "environment" JSON message followed at once by one binary frame, the KTX2 file. The receive
// thread parses it (Sh9Ktx2) and publishes the newest with one atomic reference write, like the
// sh9 messages; older cubes are dropped. Plain C#, no UnityEngine.
using System;
using System.Threading;

namespace Shlight.Lighting
{
    /// <summary>One received cube (immutable).</summary>
    public sealed class Sh9EnvironmentSnapshot
    {
        public readonly Sh9EnvironmentCube Cube;
        /// <summary>The "environment" message that announced it.</summary>
        public readonly Sh9EnvironmentAnnouncement Announcement;
        /// <summary>1, 2, 3, ... per accepted cube of this client.</summary>
        public readonly long Version;
        public readonly long ReceivedTimestamp;

        public Sh9EnvironmentSnapshot(Sh9EnvironmentCube cube, Sh9EnvironmentAnnouncement announcement, long version,
                                      long receivedTimestamp)
        {
            Cube = cube; Announcement = announcement; Version = version; ReceivedTimestamp = receivedTimestamp;
        }
    }

    public sealed partial class Sh9Client
    {
        /// <summary>Largest message accepted while the cube is subscribed (a 256² cube is 4,195,320 bytes).</summary>
        public const int EnvironmentMaxBytes = 8 << 20;

        Sh9EnvironmentAnnouncement pendingEnvironment;   // receive thread only
        Sh9EnvironmentSnapshot latestEnvironment;         // Volatile
        long environmentVersion, environmentsRejected;

        /// <summary>Raised on the receive thread for every accepted cube (never touch Unity objects in it).</summary>
        public event Action<Sh9EnvironmentSnapshot> EnvironmentReceived;

        /// <summary>The newest cube (null until the first); safe from any thread.</summary>
        public Sh9EnvironmentSnapshot LatestEnvironment { get { return Volatile.Read(ref latestEnvironment); } }
        public long EnvironmentsReceived { get { return Interlocked.Read(ref environmentVersion); } }
        public long EnvironmentsRejected { get { return Interlocked.Read(ref environmentsRejected); } }

        int MessageLimit
        {
            get { return options.Environment ? Math.Max(options.MaxMessageBytes, EnvironmentMaxBytes) : options.MaxMessageBytes; }
        }

        void HandleBinary(byte[] data, int length)
        {
            Sh9EnvironmentAnnouncement announced = pendingEnvironment;
            pendingEnvironment = null;
            if (announced == null) return;            // a binary frame nobody announced: not ours
            if (!string.IsNullOrEmpty(options.Probe) && announced.Probe != options.Probe) return;
            Sh9EnvironmentCube cube;
            try
            {
                if (announced.ByteLength >= 0 && announced.ByteLength != length)
                    throw new FormatException("announced " + announced.ByteLength + " bytes, received " + length);
                if (announced.Encoding != "ktx2") throw new FormatException("encoding \"" + announced.Encoding + "\" is not ktx2");
                cube = Sh9Ktx2.Parse(data, 0, length);
            }
            catch (FormatException e)
            {
                Interlocked.Increment(ref environmentsRejected);
                SetError("rejected a reflection cube: " + e.Message);
                return;
            }
            var snap = new Sh9EnvironmentSnapshot(cube, announced, Interlocked.Increment(ref environmentVersion),
                                                  System.Diagnostics.Stopwatch.GetTimestamp());
            Volatile.Write(ref latestEnvironment, snap);
            Action<Sh9EnvironmentSnapshot> handler = EnvironmentReceived;
            if (handler != null)
            {
                try { handler(snap); }
                catch (Exception e) { Emit("EnvironmentReceived handler threw: " + e.Message); }
            }
        }
    }
}
