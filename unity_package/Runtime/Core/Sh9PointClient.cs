// Follows the light at one point of the room (docs/probes.md "In the engines"; plain C#, no UnityEngine):
// a WebSocket to `shlight serve` subscribed with {"type":"subscribe","at":[x,y,z]} (the wire's world frame,
// metres), whose "point" messages carry the light there. Each is kept as Unity's SphericalHarmonicsL2
// values (Sh9Math: CoefficientsToUnity, then AmbientProbeFromCoefficients), for a renderer that does not
// blend light probes. Reconnects by itself (1 s, doubling to 10 s); MoveTo re-subscribes.
using System;
using System.Collections.Generic;
using System.Globalization;
using System.IO;
using System.Net.WebSockets;
using System.Text;
using System.Threading;
using System.Threading.Tasks;

namespace Shlight.Lighting
{
    public sealed class Sh9PointClient : IDisposable
    {
        readonly Uri uri;
        readonly string token;
        readonly SemaphoreSlim sending = new SemaphoreSlim(1, 1);
        readonly object gate = new object();
        readonly Sh9SocketLoop socketLoop;
        double[] at;                 // the point asked for, wire frame (under gate)
        double[] probe, coefficients, position;
        long version;
        string lastError;

        public Sh9PointClient(string serverUrl, string token, bool tokenInQuery)
        {
            uri = Sh9Client.BuildUri(serverUrl, token, tokenInQuery);
            this.token = token;
            socketLoop = new Sh9SocketLoop(gate);
        }

        public Uri Uri { get { return uri; } }
        /// <summary>Counts the point messages taken; changes when <see cref="UnityProbe"/> does.</summary>
        public long Version { get { return Interlocked.Read(ref version); } }
        /// <summary>The light at the point as SphericalHarmonicsL2 values (27, layout 9*rgb + i); null before the first.</summary>
        public double[] UnityProbe { get { lock (gate) return probe; } }
        /// <summary>The wire's coefficients of the last point message (27, index 3*i + c).</summary>
        public double[] Coefficients { get { lock (gate) return coefficients; } }
        /// <summary>Where the last point message's light is (wire frame).</summary>
        public double[] Position { get { lock (gate) return position; } }
        /// <summary>The server's last refusal or the connection's last failure; null while all is well.</summary>
        public string LastError { get { return Volatile.Read(ref lastError); } }

        public void Start() { socketLoop.Start(RunAsync); }

        /// <summary>Follow the light at (x, y, z), the wire's frame (Unity's with z negated).</summary>
        public void MoveTo(double x, double y, double z)
        {
            ClientWebSocket ws;
            lock (gate)
            {
                at = new[] { x, y, z };
                ws = socketLoop.Current;
            }
            if (ws != null && ws.State == WebSocketState.Open) Task.Run(() => SubscribeAsync(ws, CancellationToken.None));
        }

        async Task SubscribeAsync(ClientWebSocket ws, CancellationToken ct)
        {
            double[] p;
            lock (gate) p = at;
            if (p == null) return;
            string text = "{\"type\":\"subscribe\",\"at\":[" + MiniJson.Number(p[0]) + "," + MiniJson.Number(p[1]) + "," +
                          MiniJson.Number(p[2]) + "]}";
            byte[] bytes = Encoding.UTF8.GetBytes(text);
            await sending.WaitAsync(ct).ConfigureAwait(false);
            try { await ws.SendAsync(new ArraySegment<byte>(bytes), WebSocketMessageType.Text, true, ct).ConfigureAwait(false); }
            catch (Exception e) { Volatile.Write(ref lastError, e.Message); }
            finally { sending.Release(); }
        }

        async Task RunAsync(CancellationToken ct)
        {
            double backoff = 1;
            var buffer = new byte[1 << 16];
            while (!ct.IsCancellationRequested)
            {
                var ws = new ClientWebSocket();
                try
                {
                    if (!string.IsNullOrEmpty(token)) ws.Options.SetRequestHeader("Authorization", "Bearer " + token);
                    await ws.ConnectAsync(uri, ct).ConfigureAwait(false);
                    socketLoop.Attach(ws);
                    backoff = 1;
                    await SubscribeAsync(ws, ct).ConfigureAwait(false);
                    var text = new MemoryStream();
                    while (ws.State == WebSocketState.Open && !ct.IsCancellationRequested)
                    {
                        WebSocketReceiveResult r = await ws.ReceiveAsync(new ArraySegment<byte>(buffer), ct).ConfigureAwait(false);
                        if (r.MessageType == WebSocketMessageType.Close) break;
                        text.Write(buffer, 0, r.Count);
                        if (!r.EndOfMessage) continue;
                        Take(Encoding.UTF8.GetString(text.ToArray()));
                        text.SetLength(0);
                    }
                }
                catch (OperationCanceledException) { }
                catch (Exception e) { Volatile.Write(ref lastError, e.Message); }
                finally
                {
                    socketLoop.Detach(ws);
                    ws.Dispose();
                }
                if (ct.IsCancellationRequested) break;
                try { await Task.Delay(TimeSpan.FromSeconds(backoff), ct).ConfigureAwait(false); }
                catch (OperationCanceledException) { break; }
                backoff = Math.Min(10, backoff * 2);
            }
        }

        /// <summary>Take one message: a "point" for the point asked for, or the server's "error".</summary>
        internal void Take(string message)
        {
            Dictionary<string, object> o;
            try { o = MiniJson.ParseObject(message); }
            catch (Exception) { return; }
            object type;
            o.TryGetValue("type", out type);
            if ("error".Equals(type))
            {
                object detail;
                Volatile.Write(ref lastError, o.TryGetValue("detail", out detail) ? Convert.ToString(detail, CultureInfo.InvariantCulture) : "error");
                return;
            }
            if (!"point".Equals(type)) return;
            double[] c = Numbers(o, "coefficients", 27), p = Numbers(o, "position", 3);
            if (c == null || p == null) return;
            double[] u = Sh9Math.AmbientProbeFromCoefficients(Sh9Math.CoefficientsToUnity(c));
            lock (gate)
            {
                // a message for a point asked for before the last MoveTo is not this point's light
                if (at == null || p[0] != at[0] || p[1] != at[1] || p[2] != at[2]) return;
                probe = u;
                coefficients = c;
                position = p;
            }
            Interlocked.Increment(ref version);
            Volatile.Write(ref lastError, null);
        }

        static double[] Numbers(Dictionary<string, object> o, string key, int n)
        {
            object v;
            var list = o.TryGetValue(key, out v) ? v as List<object> : null;
            if (list == null || list.Count != n) return null;
            var r = new double[n];
            for (int i = 0; i < n; i++)
            {
                if (!(list[i] is double)) return null;
                r[i] = (double)list[i];
                if (double.IsNaN(r[i]) || double.IsInfinity(r[i])) return null;
            }
            return r;
        }

        public void Dispose() { socketLoop.Stop(2000, null); }
    }
}
