// Fills Unity's light probes from the server's grid of light between its probes (/probe-grid.json;
// docs/probes.md "In the engines"), so that every renderer blending light probes gets the light where
// it stands, through Unity's own tetrahedral interpolation, without a shader change.
//
// Every refreshSeconds it asks for the grid of the box (Unity's frame, metres) at the given step, with
// the client's token; converts each point's SH9 to Unity's frame and SphericalHarmonicsL2 layout as the
// ambient probe is converted (Sh9ProbeGrid); sets LightmapSettings.lightProbes' positions and bakedProbes,
// and re-tetrahedralises only when the points moved (a new box or step), as that is the costly part.
//
// Unity 2023.2 or newer (LightProbes.SetPositionsSelf, LightProbes.Tetrahedralize). Unity fills light
// probes only into a LightProbes object the scene already has: bake one Light Probe Group (one probe is
// enough) in the scene. The server needs several positioned probes (docs/probes.md).
using System;
using UnityEngine;
using UnityEngine.Networking;
using UnityEngine.Rendering;

namespace Shlight.Lighting
{
    [AddComponentMenu("Lighting/SH9 Probe Grid (shlight)")]
    [DisallowMultipleComponent]
    public sealed class SH9ProbeGrid : SH9ServerComponent
    {
        [Tooltip("The box the grid fills, in this scene's world frame (metres): the room, or the part holograms use.")]
        [SerializeField] Vector3 boxMin = new Vector3(0, 0, -5);
        [SerializeField] Vector3 boxMax = new Vector3(6, 3, 0);
        [Tooltip("Metres between grid points. The server answers at most 512 points.")]
        [Min(0.05f)] [SerializeField] float step = 1f;
        [Tooltip("Seconds between fetches of the grid (each costs the server one light computation per point).")]
        [Min(0.1f)] [SerializeField] float refreshSeconds = 2f;

        UnityWebRequest request;
        float nextFetch;
        Sh9ProbeGrid applied;
        string lastError;
        int fills, tetrahedralizations;

        public Vector3 BoxMin { get { return boxMin; } set { boxMin = value; } }
        public Vector3 BoxMax { get { return boxMax; } set { boxMax = value; } }
        public float Step { get { return step; } set { step = value; } }
        public float RefreshSeconds { get { return refreshSeconds; } set { refreshSeconds = value; } }
        /// <summary>The grid last put into the light probes (null before the first).</summary>
        public Sh9ProbeGrid Grid { get { return applied; } }
        /// <summary>Why the last fetch or fill failed; null after a good one.</summary>
        public string LastError { get { return lastError; } }
        /// <summary>Grids put into the light probes, and how many of those moved them (re-tetrahedralised).</summary>
        public int Fills { get { return fills; } }
        public int Tetrahedralizations { get { return tetrahedralizations; } }

        void OnEnable() { nextFetch = 0; }

        void OnDisable()
        {
            if (request != null) { request.Dispose(); request = null; }
        }

        void Update()
        {
            if (request != null)
            {
                if (!request.isDone) return;
                Finish(request);
                request.Dispose();
                request = null;
            }
            if (Time.unscaledTime >= nextFetch) Send();
        }

        void Send()
        {
            nextFetch = Time.unscaledTime + refreshSeconds;
            string tok = UsedToken;
            Uri uri;
            try
            {
                uri = Sh9ProbeGrid.GridUri(UsedServerUrl, tok, UsedTokenInQuery, new double[] { boxMin.x, boxMin.y, boxMin.z },
                                           new double[] { boxMax.x, boxMax.y, boxMax.z }, step);
            }
            catch (ArgumentException e) { lastError = e.Message; return; }
            request = UnityWebRequest.Get(uri.AbsoluteUri);
            if (!string.IsNullOrEmpty(tok)) request.SetRequestHeader("Authorization", "Bearer " + tok);
            request.SendWebRequest();
        }

        void Finish(UnityWebRequest done)
        {
            if (done.result != UnityWebRequest.Result.Success)
            {
                // the server's 400s say what is wrong with the box in their body's "detail"
                lastError = "probe grid: " + done.error + (done.responseCode >= 400 ? ": " + done.downloadHandler.text : "");
                return;
            }
            Sh9ProbeGrid grid;
            try { grid = Sh9ProbeGrid.Parse(done.downloadHandler.text); }
            catch (FormatException e) { lastError = "probe grid: " + e.Message; return; }
            Fill(grid);
        }

        /// <summary>Put <paramref name="grid"/> into the scene's light probes (what each fetch does).</summary>
        public bool Fill(Sh9ProbeGrid grid)
        {
            if (grid == null) throw new ArgumentNullException("grid");
            bool moved = !grid.SamePositions(applied);
            string error = Apply(grid, moved);
            if (error != null)
            {
                lastError = error;
                return false;
            }
            if (moved) tetrahedralizations++;
            applied = grid;
            fills++;
            lastError = null;
            return true;
        }

        // The LightProbes calls: null when done, else why not.
        static string Apply(Sh9ProbeGrid grid, bool moved)
        {
#if UNITY_2023_2_OR_NEWER
            LightProbes probes = LightmapSettings.lightProbes;
            if (probes == null)
                return "the scene has no light probes to fill: bake a Light Probe Group (one probe is enough)";
            int n = grid.Count;
            if (moved)
            {
                var positions = new Vector3[n];
                for (int i = 0; i < n; i++)
                    positions[i] = new Vector3((float)grid.UnityPositions[3 * i], (float)grid.UnityPositions[3 * i + 1],
                                               (float)grid.UnityPositions[3 * i + 2]);
                if (!probes.SetPositionsSelf(positions, false))   // a grid has no duplicate points
                    return "Unity refused the grid's positions";
            }
            var sh = new SphericalHarmonicsL2[n];
            for (int i = 0; i < n; i++)
                for (int c = 0; c < 3; c++)
                    for (int k = 0; k < 9; k++)
                        sh[i][c, k] = (float)grid.UnityProbes[27 * i + 9 * c + k];
            probes.bakedProbes = sh;
            // the costly part, only when the points moved: Unity rebuilds its tetrahedra
            if (moved) LightProbes.Tetrahedralize();
            return null;
#else
            return "SH9ProbeGrid needs Unity 2023.2 or newer (LightProbes.SetPositionsSelf)";
#endif
        }
    }
}
