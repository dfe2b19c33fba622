// Sample: spawns a few spheres in front of the user, lit by the room through SH9LightingClient,
// and a text label with the connection state. Put it on an empty GameObject next to (or under)
// an SH9LightingClient; see README.md in this folder.
using UnityEngine;
using Shlight.Lighting;

public class SH9SampleSetup : MonoBehaviour
{
    [Tooltip("The client to show (found in the scene if empty).")]
    public SH9LightingClient client;
    [Tooltip("Material with the 'Shlight/SH9 Diffuse' shader (the sample's SH9 Diffuse White.mat).")]
    public Material sh9Material;
    [Tooltip("Optional: a Standard-shader material, lit through RenderSettings.ambientProbe when the " +
             "client's 'Drive Ambient Probe' is on, for side-by-side comparison.")]
    public Material standardMaterial;
    [Tooltip("Where to put the spheres, relative to this object.")]
    public Vector3 offset = new Vector3(0f, 0f, 1.5f);
    public float sphereSize = 0.2f;

    TextMesh label;
    static readonly int ColorId = Shader.PropertyToID("_Color");

    void Start()
    {
        if (client == null) client = FindObjectOfType<SH9LightingClient>();
        if (sh9Material == null)
        {
            Shader shader = Shader.Find("Shlight/SH9 Diffuse");
            if (shader != null) sh9Material = new Material(shader);
            else Debug.LogWarning("SH9 sample: assign sh9Material (Shader.Find only sees shaders that are in the build)", this);
        }
        Spawn("SH9 white", sh9Material, -1.5f, Color.white);
        Spawn("SH9 tinted", sh9Material, 0f, new Color(0.8f, 0.5f, 0.3f));
        if (standardMaterial != null) Spawn("Standard (ambient probe)", standardMaterial, 1.5f, Color.white);

        var labelObject = new GameObject("SH9 status");
        labelObject.transform.SetParent(transform, false);
        labelObject.transform.localPosition = offset + Vector3.up * (sphereSize * 1.5f);
        label = labelObject.AddComponent<TextMesh>();
        label.anchor = TextAnchor.LowerCenter;
        label.characterSize = 0.01f;
        label.fontSize = 48;
        label.color = Color.white;
    }

    void Spawn(string objectName, Material material, float slot, Color tint)
    {
        if (material == null) return;
        GameObject sphere = GameObject.CreatePrimitive(PrimitiveType.Sphere);
        sphere.name = objectName;
        sphere.transform.SetParent(transform, false);
        sphere.transform.localPosition = offset + Vector3.right * (slot * sphereSize * 1.3f);
        sphere.transform.localScale = new Vector3(sphereSize, sphereSize, sphereSize);
        // One shared material, the colour per renderer: with GPU instancing the spheres still draw
        // together and each keeps its colour (_Color is a per-instance property of SH9 Diffuse).
        Renderer renderer = sphere.GetComponent<Renderer>();
        renderer.sharedMaterial = material;
        var block = new MaterialPropertyBlock();
        block.SetColor(ColorId, tint);
        renderer.SetPropertyBlock(block);
    }

    void Update()
    {
        if (label == null) return;
        if (client == null) { label.text = "no SH9LightingClient in the scene"; return; }
        string text = client.State + (client.HasLighting ? "  seq " + client.LastSeq + "  age " + client.AgeSeconds.ToString("0.0") + " s" : "");
        if (client.State != Sh9ConnectionState.Live && !string.IsNullOrEmpty(client.LastError))
            text += "\n" + client.LastError;
        label.text = text;
    }
}
