// What SH9PointLight and SH9ProbeGrid both ask for in the inspector: the server to ask and its token, typed
// here or taken from a SH9LightingClient. The fields keep the names these components saved before they
// shared them, so scenes and prefabs load as they were.
using UnityEngine;

namespace Shlight.Lighting
{
    public abstract class SH9ServerComponent : MonoBehaviour
    {
        [Tooltip("Take the server address and token from this client (leave empty to type them here).")]
        [SerializeField] SH9LightingClient client;
        [SerializeField] string serverUrl = "ws://127.0.0.1:8765/";
        [Tooltip("The server's --token. Sent as 'Authorization: Bearer <token>'.")]
        [SerializeField] string token = "";
        [SerializeField] bool tokenInQuery = false;

        public SH9LightingClient Client { get { return client; } set { client = value; } }
        public string ServerUrl { get { return serverUrl; } set { serverUrl = value; } }
        public string Token { get { return token; } set { token = value; } }
        public bool TokenInQuery { get { return tokenInQuery; } set { tokenInQuery = value; } }

        /// <summary>The server address in use: the client's when one is set, else the one typed here.</summary>
        protected string UsedServerUrl { get { return client != null ? client.ServerUrl : serverUrl; } }
        /// <summary>The token in use: the client's when one is set, else the one typed here.</summary>
        protected string UsedToken { get { return client != null ? client.Token : token; } }
        /// <summary>Whether the token goes in the query too: the client's choice when one is set.</summary>
        protected bool UsedTokenInQuery { get { return client != null ? client.TokenInQuery : tokenInQuery; } }
    }
}
