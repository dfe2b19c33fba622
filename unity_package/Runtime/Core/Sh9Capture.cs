// The headset's side of /capture (docs/passthrough.md, "The live route"; docs/contract.md §15): a view's
// "view" message from a Unity camera pose and a camera's intrinsics, and the socket that sends each view's
// message and JPEG and hands the answers to a Sh9PassthroughState. Plain C#, no UnityEngine:
// SH9PassthroughSender feeds it from Meta's Passthrough Camera API; the Mono tests drive it against a real server.
using System;
using System.Globalization;
using System.IO;
using System.Net.WebSockets;
using System.Text;
using System.Threading;
using System.Threading.Tasks;

namespace Shlight.Lighting
{
    /// <summary>A view's pose and intrinsics in the wire's conventions.</summary>
    public static class Sh9CaptureView
    {
        /// <summary>
        /// The camera-to-world 4×4 (16 numbers, row-major) of transforms.json: OpenGL camera axes (looks down −Z,
        /// +Y up, +X right) in the probe's right-handed frame (docs/contract.md §1). In: a Unity camera pose
        /// (position, rotation; the camera looks along its +Z as Unity's cameras do) and the probe's anchor (the
        /// transform SH9LightingClient turns the lighting by: where the 360° camera is and how it is turned), both
        /// in Unity world coordinates. The pose relative to the anchor is R = Aᵀ·Q, p = Aᵀ·(c − a); Unity is
        /// left-handed, so with S = diag(1, 1, −1) the matrix is S·R·S (whose third column is the camera's back,
        /// −forward) and the position S·p.
        /// </summary>
        public static double[] TransformMatrix(double[] cameraPosition, double[] cameraRotation,
                                               double[] anchorPosition, double[] anchorRotation)
        {
            double[] q = Sh9Math.QuaternionToMatrix(cameraRotation[0], cameraRotation[1], cameraRotation[2], cameraRotation[3]);
            double[] a = Sh9Math.QuaternionToMatrix(anchorRotation[0], anchorRotation[1], anchorRotation[2], anchorRotation[3]);
            var r = new double[9];
            var p = new double[3];
            for (int i = 0; i < 3; i++)
            {
                for (int j = 0; j < 3; j++)
                    for (int k = 0; k < 3; k++) r[3 * i + j] += a[3 * k + i] * q[3 * k + j];   // Aᵀ Q
                for (int k = 0; k < 3; k++) p[i] += a[3 * k + i] * (cameraPosition[k] - anchorPosition[k]);
            }
            var m = new double[16];
            for (int i = 0; i < 3; i++)
            {
                for (int j = 0; j < 3; j++)
                    m[4 * i + j] = (i == 2 ? -1 : 1) * (j == 2 ? -1 : 1) * r[3 * i + j];      // S R S
                m[4 * i + 3] = (i == 2 ? -1 : 1) * p[i];
            }
            m[15] = 1;
            return m;
        }

        /// <summary>
        /// (fl_x, fl_y, cx, cy) of an image of <paramref name="width"/> × <paramref name="height"/> pixels (x right,
        /// y down from the top row) from a Passthrough Camera API camera's intrinsics, read as its
        /// ViewportPointToRay reads them: focal length and principal point in sensor pixels of a
        /// <paramref name="sensorWidth"/> × <paramref name="sensorHeight"/> sensor, y up from the bottom; the image is
        /// the sensor's centred crop of the image's aspect, scaled (MRUK's CalcSensorCropRegion).
        /// </summary>
        public static double[] Intrinsics(double focalX, double focalY, double principalX, double principalY,
                                          double sensorWidth, double sensorHeight, int width, int height)
        {
            double sx = width / sensorWidth, sy = height / sensorHeight, s = Math.Max(sx, sy);
            sx /= s;
            sy /= s;
            double cropX = sensorWidth * (1 - sx) * 0.5, cropY = sensorHeight * (1 - sy) * 0.5;
            double cropW = sensorWidth * sx, cropH = sensorHeight * sy;
            double kx = width / cropW, ky = height / cropH;
            return new[] { focalX * kx, focalY * ky, (principalX - cropX) * kx, height - (principalY - cropY) * ky };
        }

        /// <summary>The "view" message: transform_matrix (16 numbers), fl_x fl_y cx cy w h, time.</summary>
        public static string Message(double[] transformMatrix, double[] intrinsics, int width, int height, double time)
        {
            var sb = new StringBuilder(512);
            sb.Append("{\"type\":\"view\",\"transform_matrix\":[");
            for (int i = 0; i < 16; i++) sb.Append(i == 0 ? "" : ",").Append(MiniJson.Number(transformMatrix[i]));
            sb.Append("],\"fl_x\":").Append(MiniJson.Number(intrinsics[0]))
              .Append(",\"fl_y\":").Append(MiniJson.Number(intrinsics[1]))
              .Append(",\"cx\":").Append(MiniJson.Number(intrinsics[2]))
              .Append(",\"cy\":").Append(MiniJson.Number(intrinsics[3]))
              .Append(",\"w\":").Append(width.ToString(CultureInfo.InvariantCulture))
              .Append(",\"h\":").Append(height.ToString(CultureInfo.InvariantCulture))
              .Append(",\"time\":").Append(MiniJson.Number(time)).Append('}');
            return sb.ToString();
        }
    }

    /// <summary>
    /// One headset's socket on /capture: <see cref="TrySend"/> sends a view's message and its JPEG when the last
    /// view was answered (one view in flight at most: a headset never queues views), the receive loop hands every
    /// answer to <see cref="State"/>. Reconnects with a backoff; the same token as the lighting client
    /// ("Authorization: Bearer").
    /// </summary>
    public sealed class Sh9CaptureClient : IDisposable
    {
        readonly string token;
        readonly Sh9SocketLoop socketLoop = new Sh9SocketLoop(new object());
        int inFlight;                      // 1 while a sent view waits for its answer (Interlocked)
        long sentAt;                       // Stopwatch timestamp of the last send
        long viewsSent, viewsSkipped;
        string lastError;

        /// <summary>Seconds after which an unanswered view no longer holds the next one back.</summary>
        public double AnswerTimeoutSeconds = 10;
        public readonly Sh9PassthroughState State = new Sh9PassthroughState();
        public Uri Uri { get; private set; }
        /// <summary>Raised on the receive thread for each text message (never touch Unity objects in it).</summary>
        public event Action<string> MessageReceived;

        public Sh9CaptureClient(string serverUrl, string token, bool tokenInQuery, string probe)
        {
            this.token = token;
            var b = new UriBuilder(Sh9Client.BuildUri(serverUrl, token, tokenInQuery));
            b.Path = b.Path.TrimEnd('/') + "/capture";
            if (!string.IsNullOrEmpty(probe))
            {
                string q = b.Query.TrimStart('?');
                b.Query = (q.Length == 0 ? "" : q + "&") + "probe=" + Uri.EscapeDataString(probe);
            }
            Uri = b.Uri;
        }

        public bool Connected { get { ClientWebSocket ws = socketLoop.Current; return ws != null && ws.State == WebSocketState.Open; } }
        public long ViewsSent { get { return Interlocked.Read(ref viewsSent); } }
        /// <summary>Views not sent because the last one was not answered yet or the socket was down.</summary>
        public long ViewsSkipped { get { return Interlocked.Read(ref viewsSkipped); } }
        public string LastError { get { return Volatile.Read(ref lastError); } }

        public void Start() { socketLoop.Start(RunAsync); }

        public void Stop(int waitMilliseconds = 1000) { socketLoop.Stop(waitMilliseconds, null); }

        public void Dispose() { Stop(); }

        /// <summary>Send one view (its "view" message, then its JPEG) unless the socket is down or the last view
        /// is unanswered; returns at once (the send runs on the thread pool).</summary>
        public bool TrySend(string viewMessage, byte[] jpeg)
        {
            ClientWebSocket ws = socketLoop.Current;
            long now = System.Diagnostics.Stopwatch.GetTimestamp();
            bool stale = (now - Interlocked.Read(ref sentAt)) > AnswerTimeoutSeconds * System.Diagnostics.Stopwatch.Frequency;
            if (ws == null || ws.State != WebSocketState.Open ||
                (Interlocked.CompareExchange(ref inFlight, 1, 0) != 0 && !stale))
            {
                Interlocked.Increment(ref viewsSkipped);
                return false;
            }
            Interlocked.Exchange(ref inFlight, 1);
            Interlocked.Exchange(ref sentAt, now);
            Interlocked.Increment(ref viewsSent);
            CancellationToken ct = socketLoop.Token;
            Task.Run(async () =>
            {
                try
                {
                    byte[] text = Encoding.UTF8.GetBytes(viewMessage);
                    await ws.SendAsync(new ArraySegment<byte>(text), WebSocketMessageType.Text, true, ct).ConfigureAwait(false);
                    await ws.SendAsync(new ArraySegment<byte>(jpeg), WebSocketMessageType.Binary, true, ct).ConfigureAwait(false);
                }
                catch (Exception e)
                {
                    Volatile.Write(ref lastError, "sending a view failed: " + e.Message);
                    Interlocked.Exchange(ref inFlight, 0);
                }
            });
            return true;
        }

        async Task RunAsync(CancellationToken ct)
        {
            double backoff = 0.5;
            while (!ct.IsCancellationRequested)
            {
                var ws = new ClientWebSocket();
                try
                {
                    if (!string.IsNullOrEmpty(token)) ws.Options.SetRequestHeader("Authorization", "Bearer " + token);
                    using (var connect = CancellationTokenSource.CreateLinkedTokenSource(ct))
                    {
                        connect.CancelAfter(TimeSpan.FromSeconds(5));
                        await ws.ConnectAsync(Uri, connect.Token).ConfigureAwait(false);
                    }
                    Interlocked.Exchange(ref inFlight, 0);
                    socketLoop.Attach(ws);
                    backoff = 0.5;
                    await ReceiveAsync(ws, ct).ConfigureAwait(false);
                }
                catch (Exception e)
                {
                    if (ct.IsCancellationRequested) break;
                    Volatile.Write(ref lastError, "/capture: " + e.Message);
                }
                finally
                {
                    socketLoop.Detach(ws);
                    try { ws.Abort(); } catch (Exception) { }
                    ws.Dispose();
                }
                try { await Task.Delay(TimeSpan.FromSeconds(backoff), ct).ConfigureAwait(false); }
                catch (OperationCanceledException) { break; }
                backoff = Math.Min(10, backoff * 2);
            }
        }

        async Task ReceiveAsync(ClientWebSocket ws, CancellationToken ct)
        {
            var buffer = new byte[16 * 1024];
            var message = new MemoryStream();
            while (ws.State == WebSocketState.Open && !ct.IsCancellationRequested)
            {
                message.SetLength(0);
                WebSocketReceiveResult r;
                do
                {
                    r = await ws.ReceiveAsync(new ArraySegment<byte>(buffer), ct).ConfigureAwait(false);
                    if (r.MessageType == WebSocketMessageType.Close) return;
                    message.Write(buffer, 0, r.Count);
                    if (message.Length > (1 << 20)) throw new InvalidDataException("an answer larger than 1 MiB");
                } while (!r.EndOfMessage);
                if (r.MessageType != WebSocketMessageType.Text) continue;
                string text = Encoding.UTF8.GetString(message.GetBuffer(), 0, (int)message.Length);
                Sh9PassthroughKind kind = State.Handle(text);
                // every view is answered by one "passthrough" (or an error): the next one may go
                if (kind == Sh9PassthroughKind.Answer || kind == Sh9PassthroughKind.Error) Interlocked.Exchange(ref inFlight, 0);
                if (kind == Sh9PassthroughKind.Error) Volatile.Write(ref lastError, "server: " + State.LastError);
                Action<string> handler = MessageReceived;
                if (handler != null) { try { handler(text); } catch (Exception) { } }
            }
        }
    }
}
