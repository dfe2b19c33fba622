// WebSocket client for `shlight serve` (plain C#, no UnityEngine).
//
// Uses System.Net.WebSockets.ClientWebSocket (available in Unity's .NET Standard 2.0 / .NET 4.x
// profiles, on UWP/IL2CPP and on Mono). The receive loop runs on a thread-pool task and never
// touches Unity objects: it parses each text frame, converts it to Unity's frame and publishes
// the newest result with one atomic reference write (Volatile.Write). The main thread reads
// <see cref="Latest"/> whenever it likes; older messages are simply dropped (docs/contract.md §6: only
// the latest coefficients matter). On any failure it reconnects with exponential backoff and
// keeps the last lighting.
using System;
using System.IO;
using System.Net.Security;
using System.Security.Authentication;
using System.Net.Sockets;
using System.Net.WebSockets;
using System.Text;
using System.Threading;
using System.Threading.Tasks;

namespace Shlight.Lighting
{
    public enum Sh9ConnectionState
    {
        /// <summary>Not connected (stopped, or waiting before the next reconnect attempt).</summary>
        Disconnected = 0,
        /// <summary>Opening the connection, or connected and waiting for the first message.</summary>
        Connecting = 1,
        /// <summary>Receiving fresh coefficients.</summary>
        Live = 2,
        /// <summary>Connected, but the server says its source is down ("stale": true) or nothing
        /// arrived for <see cref="Sh9ClientOptions.StaleAfterSeconds"/>. The last lighting is kept.</summary>
        Stale = 3,
    }

    public sealed class Sh9ClientOptions
    {
        /// <summary>ws://HOST:8765/ of the PC running `shlight serve` ("HOST:PORT" is accepted too).</summary>
        public string Url = "ws://127.0.0.1:8765/";
        /// <summary>The server's --token; sent as "Authorization: Bearer TOKEN" (empty: none).</summary>
        public string Token = "";
        /// <summary>Also send the token as ?token=... (for proxies that drop the header).</summary>
        public bool TokenInQuery;
        /// <summary>Probe to subscribe to; empty accepts whatever probe the server sends.</summary>
        public string Probe = "default";
        /// <summary>Highest message rate to ask the server for (0: server default).</summary>
        public double MaxHz = 30;
        /// <summary>Connected but silent for this long counts as Stale.</summary>
        public double StaleAfterSeconds = 3;
        public double MinBackoffSeconds = 0.5;
        public double MaxBackoffSeconds = 10;
        public double ConnectTimeoutSeconds = 5;
        /// <summary>Reconnect when nothing at all arrives for this long (a half-open Wi-Fi
        /// connection); 0 disables it.</summary>
        public double ReceiveTimeoutSeconds = 30;
        public int MaxMessageBytes = 1 << 20;
        /// <summary>Also subscribe to the reflection cube (docs/contract.md §12): <see cref="Sh9Client.LatestEnvironment"/>.
        /// Messages up to <see cref="Sh9Client.EnvironmentMaxBytes"/> are then accepted (a 256² cube is 4.2 MB).</summary>
        public bool Environment;
        /// <summary>Draw the key light (the brightest, <see cref="Sh9Shadows.KeyLightIndex"/>) as the Unity
        /// light instead of the message's first light: the one whose shadow a shadow catcher shows.</summary>
        public bool DrawKeyLight;

        public Sh9ClientOptions Clone() { return (Sh9ClientOptions)MemberwiseClone(); }
    }

    public sealed partial class Sh9Client : IDisposable
    {
        readonly Sh9ClientOptions options;
        readonly object gate = new object();
        readonly Sh9SocketLoop socketLoop;
        int keyLight = -1;   // the last key light's index (receive thread only)

        Sh9Snapshot latest;        // published with Volatile.Write, read with Volatile.Read
        Sh9Hello hello;
        string lastError;
        long version;              // Interlocked
        long versionAtConnect;
        long received, rejected, ignored;
        int connections;
        int phase;                 // 0 disconnected, 1 connecting, 2 connected (Volatile)
        int httpStatus;            // status of the last refused handshake (Volatile)
        long lastFrameTimestamp;   // any frame, for the receive timeout and SecondsSinceLastFrame
        volatile bool watchdogFired;
        volatile bool reconnectRequested;
        CancellationTokenSource backoffWait; // the pending backoff delay (under gate), cancelled by ReconnectNow

        /// <summary>Raised on the receive thread for every accepted "sh9" message (never touch Unity objects in it).</summary>
        public event Action<Sh9Snapshot> SnapshotReceived;
        /// <summary>Diagnostics, raised on the receive thread.</summary>
        public event Action<string> Log;

        public Sh9Client(Sh9ClientOptions options)
        {
            if (options == null) throw new ArgumentNullException("options");
            this.options = options.Clone();
            socketLoop = new Sh9SocketLoop(gate);
            Uri = BuildUri(this.options.Url, this.options.Token, this.options.TokenInQuery);
        }

        public Uri Uri { get; private set; }
        public Sh9ClientOptions Options { get { return options.Clone(); } }

        /// <summary>Newest accepted message (null until the first one); safe from any thread.</summary>
        public Sh9Snapshot Latest { get { return Volatile.Read(ref latest); } }
        /// <summary>The server's hello of the current or last connection.</summary>
        public Sh9Hello Hello { get { return Volatile.Read(ref hello); } }
        /// <summary>Why the last connection failed or what the server complained about.</summary>
        public string LastError { get { return Volatile.Read(ref lastError); } }
        public long MessagesReceived { get { return Interlocked.Read(ref received); } }
        public long MessagesRejected { get { return Interlocked.Read(ref rejected); } }
        /// <summary>HTTP status with which the server refused the last WebSocket handshake (401: wrong
        /// or missing token, 403: Origin, 404: wrong path or probe, 503: too many clients); 0 when
        /// the last attempt was not refused that way.</summary>
        public int HandshakeStatus { get { return Volatile.Read(ref httpStatus); } }
        /// <summary>Successful connections so far (1 + reconnects).</summary>
        public int Connections { get { return Volatile.Read(ref connections); } }
        public bool IsRunning { get { return socketLoop.IsRunning; } }

        /// <summary>Seconds since the last frame of any kind arrived on a connection (-1 before the first).</summary>
        public double SecondsSinceLastFrame
        {
            get
            {
                long t = Volatile.Read(ref lastFrameTimestamp);
                if (t == 0) return -1;
                return (System.Diagnostics.Stopwatch.GetTimestamp() - t) / (double)System.Diagnostics.Stopwatch.Frequency;
            }
        }

        /// <summary>
        /// Drop the current connection (or connection attempt, or backoff wait) and connect again at
        /// once, with the backoff reset; the last lighting is kept. For an app coming back from suspend:
        /// its socket may be dead without either side having noticed (the OS froze the app; Wi-Fi slept),
        /// and only the receive watchdog would notice, <see cref="Sh9ClientOptions.ReceiveTimeoutSeconds"/>
        /// later. Safe from any thread; does nothing when the client is not running.
        /// </summary>
        public void ReconnectNow(string reason)
        {
            ClientWebSocket ws;
            CancellationTokenSource wait;
            lock (gate)
            {
                if (!socketLoop.IsRunning) return;
                reconnectRequested = true;
                ws = socketLoop.Current;
                wait = backoffWait;
            }
            Emit("reconnecting now" + (string.IsNullOrEmpty(reason) ? "" : " (" + reason + ")"));
            if (ws != null)
            {
                try { ws.Abort(); } catch (Exception) { }
            }
            if (wait != null)
            {
                try { wait.Cancel(); } catch (ObjectDisposedException) { }
            }
        }

        public Sh9ConnectionState State
        {
            get
            {
                int p = Volatile.Read(ref phase);
                if (p == 0) return Sh9ConnectionState.Disconnected;
                if (p == 1) return Sh9ConnectionState.Connecting;
                Sh9Snapshot s = Latest;
                if (s == null || s.Version <= Interlocked.Read(ref versionAtConnect))
                    return Sh9ConnectionState.Connecting;
                if (s.Message.Stale || s.SecondsSinceReceived > options.StaleAfterSeconds)
                    return Sh9ConnectionState.Stale;
                return Sh9ConnectionState.Live;
            }
        }

        /// <summary>Seconds since the newest coefficients were captured (server age + time since received); -1 if none.</summary>
        public double AgeSeconds
        {
            get
            {
                Sh9Snapshot s = Latest;
                return s == null ? -1 : s.Message.AgeSeconds + s.SecondsSinceReceived;
            }
        }

        /// <summary>Start the background connection loop (idempotent).</summary>
        public void Start() { socketLoop.Start(RunAsync); }

        /// <summary>Stop and close the connection; waits up to <paramref name="waitMilliseconds"/>.</summary>
        public void Stop(int waitMilliseconds = 2000)
        {
            // Say goodbye properly (a close frame) when we can do so quickly, then tear down.
            bool stopped = socketLoop.Stop(waitMilliseconds, ws =>
            {
                if (ws.State != WebSocketState.Open) return;
                try
                {
                    ws.CloseOutputAsync(WebSocketCloseStatus.NormalClosure, "client stopped", CancellationToken.None)
                      .Wait(Math.Min(300, Math.Max(0, waitMilliseconds)));
                }
                catch (Exception) { }
            });
            if (stopped) Volatile.Write(ref phase, 0);
        }

        public void Dispose() { Stop(); }

        /// <summary>
        /// Normalise the server address: "HOST:PORT" gets ws://, http(s) becomes ws(s), a missing
        /// path becomes "/", and with <paramref name="tokenInQuery"/> the token is appended.
        /// </summary>
        public static Uri BuildUri(string url, string token, bool tokenInQuery)
        {
            if (string.IsNullOrEmpty(url) || url.Trim().Length == 0)
                throw new ArgumentException("server URL is empty");
            url = url.Trim();
            if (url.StartsWith("http://", StringComparison.OrdinalIgnoreCase)) url = "ws://" + url.Substring(7);
            else if (url.StartsWith("https://", StringComparison.OrdinalIgnoreCase)) url = "wss://" + url.Substring(8);
            else if (url.IndexOf("://", StringComparison.Ordinal) < 0) url = "ws://" + url;
            var b = new UriBuilder(url);
            if (b.Scheme != "ws" && b.Scheme != "wss")
                throw new ArgumentException("server URL must start with ws:// or wss://: " + url);
            if (string.IsNullOrEmpty(b.Path)) b.Path = "/";
            if (tokenInQuery && !string.IsNullOrEmpty(token))
            {
                string q = b.Query.TrimStart('?');
                string t = "token=" + Uri.EscapeDataString(token);
                b.Query = q.Length == 0 ? t : q + "&" + t;
            }
            return b.Uri;
        }

        // ---- the loop ---------------------------------------------------------------------

        async Task RunAsync(CancellationToken ct)
        {
            double backoff = options.MinBackoffSeconds;
            var random = new Random();
            while (!ct.IsCancellationRequested)
            {
                Volatile.Write(ref phase, 1);
                watchdogFired = false;     // else a failed reconnect after a watchdog abort goes unreported
                reconnectRequested = false; // this attempt is the one asked for
                bool gotData = false;
                var ws = new ClientWebSocket();
                socketLoop.Attach(ws);
                try
                {
                    if (!string.IsNullOrEmpty(options.Token))
                        ws.Options.SetRequestHeader("Authorization", "Bearer " + options.Token);
                    ws.Options.KeepAliveInterval = TimeSpan.FromSeconds(10);
                    using (var connectCts = CancellationTokenSource.CreateLinkedTokenSource(ct))
                    {
                        connectCts.CancelAfter(TimeSpan.FromSeconds(options.ConnectTimeoutSeconds));
                        try
                        {
                            // Mono's (Unity's) ConnectAsync ignores the token once the TCP connection is
                            // up: a server that accepts but never answers the handshake would hang it
                            // forever. So wait with a deadline of our own, then abort the socket.
                            Task connect = ws.ConnectAsync(Uri, connectCts.Token);
                            Task deadline = Task.Delay(Timeout.Infinite, connectCts.Token);
                            if (await Task.WhenAny(connect, deadline).ConfigureAwait(false) != connect)
                            {
                                try { ws.Abort(); } catch (Exception) { }
                                ObserveLater(connect);
                                throw new OperationCanceledException();
                            }
                            await connect.ConfigureAwait(false);
                        }
                        catch (OperationCanceledException)
                        {
                            if (ct.IsCancellationRequested) throw;
                            throw new Sh9ConnectionException("no answer from " + Uri.Host + ":" + Uri.Port +
                                " within " + options.ConnectTimeoutSeconds + " s (wrong address? server without " +
                                "--host 0.0.0.0? firewall? on HoloLens: the PrivateNetworkClientServer capability?)");
                        }
                        catch (WebSocketException e)
                        {
                            if (ct.IsCancellationRequested) throw;
                            Exception tls = Uri.Scheme == "wss" ? FindTlsError(e) : null;
                            if (tls != null)
                            {
                                Volatile.Write(ref httpStatus, 0);
                                throw new Sh9ConnectionException(TlsAdvice(tls));
                            }
                            SocketException socketError = FindSocketError(e);
                            if (socketError != null && socketError.SocketErrorCode == SocketError.ConnectionReset)
                            {
                                // TCP worked, then the server hung up on the HTTP upgrade: typically a TLS
                                // server (or TLS proxy) asked for ws:// in plain text
                                Volatile.Write(ref httpStatus, 0);
                                throw new Sh9ConnectionException(Uri.Host + ":" + Uri.Port + " reset the connection " +
                                    "when asked for a WebSocket (" + socketError.Message + "): if the server uses TLS " +
                                    "(shlight serve --tls-cert, or a TLS proxy), the URL must start with wss://");
                            }
                            if (socketError != null)
                            {
                                Volatile.Write(ref httpStatus, 0);
                                throw new Sh9ConnectionException("cannot reach " + Uri.Host + ":" + Uri.Port + ": " +
                                                      socketError.Message + " (is `shlight serve` running, " +
                                                      "with --host 0.0.0.0 when the headset is another machine? " +
                                                      "firewall?)");
                            }
                            // The TCP connection worked but the upgrade did not. Mono's (and so Unity's and
                            // IL2CPP's) ClientWebSocket then says only "Unable to connect to the remote
                            // server": ask again by hand to learn the HTTP status (401: token, ...).
                            string why = await DiagnoseHandshakeAsync(ct).ConfigureAwait(false);
                            if (why == null) throw;
                            throw new Sh9ConnectionException(why);
                        }
                    }
                    Interlocked.Exchange(ref versionAtConnect, Interlocked.Read(ref version));
                    Volatile.Write(ref httpStatus, 0);
                    Volatile.Write(ref lastError, null);
                    Interlocked.Increment(ref connections);
                    Volatile.Write(ref phase, 2);
                    Emit("connected to " + Uri.GetLeftPart(UriPartial.Path));
                    if (!string.IsNullOrEmpty(options.Probe) || options.MaxHz > 0)
                        await SendTextAsync(ws, Sh9Protocol.SubscribeMessage(
                            string.IsNullOrEmpty(options.Probe) ? "default" : options.Probe, options.MaxHz,
                            options.Environment), ct)
                            .ConfigureAwait(false);
                    gotData = await ReceiveLoopAsync(ws, ct).ConfigureAwait(false);
                }
                catch (Exception e)
                {
                    if (ct.IsCancellationRequested) break;
                    if (!watchdogFired && !reconnectRequested) SetError(Describe(e));
                }
                finally
                {
                    Volatile.Write(ref phase, 0);
                    socketLoop.Detach(ws);
                    try { ws.Abort(); } catch (Exception) { }
                    ws.Dispose();
                }
                if (ct.IsCancellationRequested) break;
                if (gotData) backoff = options.MinBackoffSeconds;
                if (!reconnectRequested)
                {
                    double delay = backoff * (0.75 + 0.5 * random.NextDouble());
                    Emit("disconnected (" + LastError + "); retrying in " + delay.ToString("0.0") + " s");
                    var wait = CancellationTokenSource.CreateLinkedTokenSource(ct);
                    lock (gate) backoffWait = wait;
                    try
                    {
                        // ReconnectNow may have come between the check above and here: then skip the wait
                        if (!reconnectRequested)
                            await Task.Delay(TimeSpan.FromSeconds(delay), wait.Token).ConfigureAwait(false);
                    }
                    catch (OperationCanceledException)
                    {
                        if (ct.IsCancellationRequested) break;
                    }
                    finally
                    {
                        lock (gate) backoffWait = null;
                        wait.Dispose();
                    }
                }
                backoff = reconnectRequested ? options.MinBackoffSeconds : Math.Min(backoff * 2, options.MaxBackoffSeconds);
            }
            Volatile.Write(ref phase, 0);
        }

        static void ObserveLater(Task t)
        {
            t.ContinueWith(x => { var ignored = x.Exception; }, TaskContinuationOptions.OnlyOnFaulted);
        }

        // The TLS handshake failed: an AuthenticationException (certificate refused), or an IOException
        // from the handshake (the server closed the stream: it does not speak TLS at all).
        static Exception FindTlsError(Exception e)
        {
            for (; e != null; e = e.InnerException)
                if (e is AuthenticationException || (e is IOException && !(e.InnerException is SocketException))) return e;
            return null;
        }

        string TlsAdvice(Exception tls)
        {
            Exception inner = tls;
            while (inner.InnerException != null) inner = inner.InnerException;
            string why = inner.Message.Split('\n')[0].Trim();
            if (!(tls is AuthenticationException))
                return "TLS handshake with " + Uri.Host + ":" + Uri.Port + " failed (" + why + "): the server closed " +
                       "the connection instead of answering TLS, so it does not serve wss:// on this port (a plain " +
                       "`shlight serve` needs ws://; for wss:// start it with --tls-cert/--tls-key or put a TLS proxy in front)";
            return "TLS handshake with " + Uri.Host + ":" + Uri.Port + " failed (" + why + "): the server's " +
                   "certificate is not accepted. It must chain to a root this device trusts, be valid now, and name \"" +
                   Uri.Host + "\" (a DNS name in its subjectAltName); a self-signed certificate is refused (see the " +
                   "README's TLS section)";
        }

        static SocketException FindSocketError(Exception e)
        {
            for (; e != null; e = e.InnerException)
            {
                var se = e as SocketException;
                if (se != null) return se;
            }
            return null;
        }

        /// <summary>
        /// Repeat the WebSocket upgrade request by hand and explain the server's HTTP answer
        /// ("the server refused the token (HTTP 401 ...)"); null when that tells nothing new.
        /// Sets <see cref="HandshakeStatus"/>.
        /// </summary>
        async Task<string> DiagnoseHandshakeAsync(CancellationToken ct)
        {
            var tcp = new TcpClient();
            try
            {
                Task work = DiagnoseAsync(tcp);
                Task timeout = Task.Delay(TimeSpan.FromSeconds(Math.Max(0.5, options.ConnectTimeoutSeconds)), ct);
                if (await Task.WhenAny(work, timeout).ConfigureAwait(false) != work) return null;
                return await ((Task<string>)work).ConfigureAwait(false);
            }
            catch (Exception)
            {
                return null;
            }
            finally
            {
                tcp.Close(); // also ends a read still waiting after a timeout
            }
        }

        async Task<string> DiagnoseAsync(TcpClient tcp)
        {
            await tcp.ConnectAsync(Uri.Host, Uri.Port).ConfigureAwait(false);
            Stream stream = tcp.GetStream();
            if (Uri.Scheme == "wss")
            {
                var ssl = new SslStream(stream, false);
                await ssl.AuthenticateAsClientAsync(Uri.Host).ConfigureAwait(false);
                stream = ssl;
            }
            var key = new byte[16];
            new Random().NextBytes(key);
            var request = new StringBuilder();
            request.Append("GET ").Append(Uri.PathAndQuery).Append(" HTTP/1.1\r\n")
                   .Append("Host: ").Append(Uri.Authority).Append("\r\n")
                   .Append("Upgrade: websocket\r\nConnection: Upgrade\r\n")
                   .Append("Sec-WebSocket-Key: ").Append(Convert.ToBase64String(key)).Append("\r\n")
                   .Append("Sec-WebSocket-Version: 13\r\n");
            if (!string.IsNullOrEmpty(options.Token))
                request.Append("Authorization: Bearer ").Append(options.Token).Append("\r\n");
            request.Append("\r\n");
            byte[] bytes = Encoding.ASCII.GetBytes(request.ToString());
            await stream.WriteAsync(bytes, 0, bytes.Length).ConfigureAwait(false);

            // Status line, headers and the start of the body (the server's explanation).
            var answer = new MemoryStream();
            var buffer = new byte[1024];
            while (answer.Length < 4096)
            {
                int n = await stream.ReadAsync(buffer, 0, buffer.Length).ConfigureAwait(false);
                if (n <= 0) break;
                answer.Write(buffer, 0, n);
                string sofar = Encoding.UTF8.GetString(answer.GetBuffer(), 0, (int)answer.Length);
                int end = sofar.IndexOf("\r\n\r\n", StringComparison.Ordinal);
                if (end >= 0 && (sofar.Length > end + 4 || sofar.StartsWith("HTTP/1.1 101", StringComparison.Ordinal)))
                    break;
            }
            string text = Encoding.UTF8.GetString(answer.GetBuffer(), 0, (int)answer.Length);
            string[] status = text.Split(new[] { "\r\n" }, StringSplitOptions.None)[0].Split(new[] { ' ' }, 3);
            int code;
            if (status.Length < 2 || !status[0].StartsWith("HTTP/", StringComparison.Ordinal) ||
                !int.TryParse(status[1], System.Globalization.NumberStyles.None,
                              System.Globalization.CultureInfo.InvariantCulture, out code))
            {
                Volatile.Write(ref httpStatus, 0);
                return "the server at " + Uri.Host + ":" + Uri.Port + " does not speak HTTP/WebSocket " +
                       "(is this the port of `shlight serve`?" +
                       (Uri.Scheme == "ws" && text.Length > 0 && text[0] == '\x15' ? " It answered with TLS: use wss://" : "") + ")";
            }
            if (code == 101) return null; // it would work now: nothing to explain
            Volatile.Write(ref httpStatus, code);
            int bodyAt = text.IndexOf("\r\n\r\n", StringComparison.Ordinal);
            string body = bodyAt < 0 ? "" : text.Substring(bodyAt + 4).Trim();
            int newline = body.IndexOf('\n');
            if (newline >= 0) body = body.Substring(0, newline).Trim();
            if (body.Length > 200) body = body.Substring(0, 200);
            string http = "HTTP " + code + (status.Length > 2 ? " " + status[2].Trim() : "") +
                          (body.Length > 0 ? ": " + body : "");
            if (code == 401)
                return (string.IsNullOrEmpty(options.Token)
                        ? "the server requires a token (" + http + "): set Token to the server's --token"
                        : "the server refused the token (" + http + "): set Token to the server's --token");
            if (code == 403)
                return "the server refused the connection (" + http + ")";
            if (code == 404)
                return "the server has no WebSocket at " + Uri.AbsolutePath + " or no such probe (" + http + ")";
            return "the server refused the WebSocket handshake (" + http + ")";
        }

        static async Task SendTextAsync(ClientWebSocket ws, string text, CancellationToken ct)
        {
            byte[] bytes = Encoding.UTF8.GetBytes(text);
            await ws.SendAsync(new ArraySegment<byte>(bytes), WebSocketMessageType.Text, true, ct)
                .ConfigureAwait(false);
        }

        async Task<bool> ReceiveLoopAsync(ClientWebSocket ws, CancellationToken ct)
        {
            bool gotData = false;
            var buffer = new byte[16 * 1024];
            var message = new MemoryStream();
            Volatile.Write(ref lastFrameTimestamp, System.Diagnostics.Stopwatch.GetTimestamp());
            watchdogFired = false;
            using (var watchdog = StartWatchdog(ws, ct))
            {
                while (ws.State == WebSocketState.Open && !ct.IsCancellationRequested)
                {
                    message.SetLength(0);
                    WebSocketReceiveResult r;
                    do
                    {
                        r = await ws.ReceiveAsync(new ArraySegment<byte>(buffer), ct).ConfigureAwait(false);
                        Volatile.Write(ref lastFrameTimestamp, System.Diagnostics.Stopwatch.GetTimestamp());
                        if (r.MessageType == WebSocketMessageType.Close)
                        {
                            SetError("server closed the connection" +
                                     (r.CloseStatus.HasValue ? " (" + (int)r.CloseStatus.Value + " " + r.CloseStatusDescription + ")" : ""));
                            try
                            {
                                using (var closeCts = new CancellationTokenSource(1000))
                                    await ws.CloseOutputAsync(WebSocketCloseStatus.NormalClosure, "", closeCts.Token)
                                        .ConfigureAwait(false);
                            }
                            catch (Exception) { }
                            return gotData;
                        }
                        message.Write(buffer, 0, r.Count);
                        if (message.Length > MessageLimit)
                            throw new InvalidDataException("message larger than " + MessageLimit + " bytes");
                    } while (!r.EndOfMessage);
                    if (r.MessageType == WebSocketMessageType.Binary)
                    {
                        HandleBinary(message.GetBuffer(), (int)message.Length);
                        continue;
                    }
                    if (r.MessageType != WebSocketMessageType.Text) continue;
                    string text = Encoding.UTF8.GetString(message.GetBuffer(), 0, (int)message.Length);
                    if (Handle(text)) gotData = true;
                }
            }
            if (!ct.IsCancellationRequested) SetError("connection lost");
            return gotData;
        }

        // Aborts the socket when nothing arrives for ReceiveTimeoutSeconds (Timer: no extra thread).
        IDisposable StartWatchdog(ClientWebSocket ws, CancellationToken ct)
        {
            if (!(options.ReceiveTimeoutSeconds > 0)) return new MemoryStream(); // a no-op IDisposable
            long limit = (long)(options.ReceiveTimeoutSeconds * System.Diagnostics.Stopwatch.Frequency);
            return new Timer(_ =>
            {
                long idle = System.Diagnostics.Stopwatch.GetTimestamp() - Volatile.Read(ref lastFrameTimestamp);
                if (idle > limit && !ct.IsCancellationRequested && ws.State == WebSocketState.Open)
                {
                    watchdogFired = true;
                    SetError("nothing received for " + options.ReceiveTimeoutSeconds + " s");
                    try { ws.Abort(); } catch (Exception) { }
                }
            }, null, 1000, 1000);
        }

        /// <summary>Handle one text frame; true when it was an accepted "sh9" message.</summary>
        bool Handle(string text)
        {
            Sh9Parsed parsed;
            try
            {
                parsed = Sh9Protocol.Parse(text);
            }
            catch (FormatException e)
            {
                Interlocked.Increment(ref rejected);
                SetError("rejected a message: " + e.Message);
                return false;
            }
            switch (parsed.Kind)
            {
                case Sh9MessageKind.Hello:
                    Volatile.Write(ref hello, parsed.Hello);
                    Emit("hello from " + parsed.Hello.Provider + ", probes: " + string.Join(", ", parsed.Hello.Probes));
                    if (!string.IsNullOrEmpty(options.Probe) && parsed.Hello.Probes.Length > 0 &&
                        Array.IndexOf(parsed.Hello.Probes, options.Probe) < 0)
                        SetError("the server has no probe \"" + options.Probe + "\" (it has: " +
                                 string.Join(", ", parsed.Hello.Probes) + ")");
                    return false;
                case Sh9MessageKind.Error:
                    SetError("server error: " + parsed.Error);
                    return false;
                case Sh9MessageKind.Environment:
                    pendingEnvironment = parsed.Environment;   // its KTX2 comes as the next (binary) frame
                    return false;
                case Sh9MessageKind.Sh9:
                    if (!string.IsNullOrEmpty(options.Probe) && parsed.Sh9.Probe != options.Probe)
                    {
                        Interlocked.Increment(ref ignored);
                        return false;
                    }
                    int drawn = 0;
                    if (options.DrawKeyLight)
                        drawn = keyLight = Sh9Shadows.KeyLightIndex(parsed.Sh9.LightIrradiance, parsed.Sh9.Lights, keyLight);
                    var snap = new Sh9Snapshot(parsed.Sh9, System.Diagnostics.Stopwatch.GetTimestamp(),
                                               Interlocked.Increment(ref version), drawn);
                    Volatile.Write(ref latest, snap);
                    Interlocked.Increment(ref received);
                    Action<Sh9Snapshot> handler = SnapshotReceived;
                    if (handler != null)
                    {
                        try { handler(snap); }
                        catch (Exception e) { Emit("SnapshotReceived handler threw: " + e.Message); }
                    }
                    return true;
                default:
                    return false;
            }
        }

        void SetError(string message)
        {
            Volatile.Write(ref lastError, message);
            Emit(message);
        }

        void Emit(string message)
        {
            Action<string> handler = Log;
            if (handler == null) return;
            try { handler(message); } catch (Exception) { }
        }

        static string Describe(Exception e)
        {
            var agg = e as AggregateException;
            if (agg != null && agg.InnerExceptions.Count == 1) e = agg.InnerExceptions[0];
            if (e is Sh9ConnectionException) return e.Message;
            var wse = e as WebSocketException;
            if (wse != null && wse.WebSocketErrorCode == WebSocketError.ConnectionClosedPrematurely)
                return "connection lost: the server went away without closing the connection (stopped, " +
                       "crashed, or the network dropped)";
            string text = e.GetType().Name + ": " + e.Message;
            string previous = e.Message;
            for (Exception inner = e.InnerException; inner != null; inner = inner.InnerException)
            {
                if (inner.Message != previous) text += " <- " + inner.Message;
                previous = inner.Message;
            }
            return text;
        }
    }

    /// <summary>A connection failure this client has already explained in words (its Message is
    /// meant for people: wrong token, server unreachable, ...).</summary>
    public sealed class Sh9ConnectionException : Exception
    {
        public Sh9ConnectionException(string message) : base(message) { }
    }
}
