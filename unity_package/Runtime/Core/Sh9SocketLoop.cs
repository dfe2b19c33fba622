// The background connection loop that Sh9Client, Sh9CaptureClient and Sh9PointClient each run (plain C#, no
// UnityEngine): one thread-pool task and the socket it has open. Start runs it once; Stop cancels it, aborts
// the socket (a pending receive then ends at once) and waits a bounded time, as a Unity main thread in
// OnDisable must never hang on a dead connection.
using System;
using System.Net.WebSockets;
using System.Threading;
using System.Threading.Tasks;

namespace Shlight.Lighting
{
    internal sealed class Sh9SocketLoop
    {
        // The owner's lock, so that its own state and the loop's change together (Monitor is re-entrant:
        // the owner may ask IsRunning or Current while it holds it).
        readonly object gate;
        CancellationTokenSource cts;
        Task loop;
        ClientWebSocket current;

        public Sh9SocketLoop(object gate)
        {
            if (gate == null) throw new ArgumentNullException("gate");
            this.gate = gate;
        }

        public bool IsRunning { get { lock (gate) return loop != null; } }

        /// <summary>The socket the loop has attached (opening or open); null between connections.</summary>
        public ClientWebSocket Current { get { lock (gate) return current; } }

        /// <summary>The running loop's token (None before the first Start): for sends made beside the loop.</summary>
        public CancellationToken Token { get { lock (gate) return cts == null ? CancellationToken.None : cts.Token; } }

        /// <summary>Run <paramref name="run"/> on the thread pool unless a loop runs already (idempotent).</summary>
        public void Start(Func<CancellationToken, Task> run)
        {
            lock (gate)
            {
                if (loop != null) return;
                cts = new CancellationTokenSource();
                CancellationToken ct = cts.Token;
                loop = Task.Run(() => run(ct));
            }
        }

        /// <summary>The loop's socket from now on: the one Stop aborts.</summary>
        public void Attach(ClientWebSocket ws) { lock (gate) current = ws; }

        /// <summary>The loop is done with <paramref name="ws"/>: forgotten unless a newer one took its place.</summary>
        public void Detach(ClientWebSocket ws) { lock (gate) if (current == ws) current = null; }

        /// <summary>
        /// Stop the loop: <paramref name="closing"/> (given the attached socket, when there is one) may say goodbye
        /// first; then the loop is cancelled, the socket aborted and the task waited for up to
        /// <paramref name="waitMilliseconds"/>. False when no loop was running.
        /// </summary>
        public bool Stop(int waitMilliseconds, Action<ClientWebSocket> closing)
        {
            Task t;
            CancellationTokenSource c;
            ClientWebSocket ws;
            lock (gate)
            {
                if (loop == null) return false;
                t = loop;
                loop = null;
                c = cts;
                ws = current;
            }
            if (closing != null && ws != null) closing(ws);
            c.Cancel();
            if (ws != null)
            {
                try { ws.Abort(); } catch (Exception) { }
            }
            try { t.Wait(waitMilliseconds); } catch (Exception) { }
            return true;
        }
    }
}
