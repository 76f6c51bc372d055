// Streams an export's tiles around the camera at play time: reads the export's tile index
// (tiles.json, written by vworld-lod export) from StreamingAssets, an absolute folder or an
// http(s) base URL; loads the tiles whose centre is within loadRadius of the camera and unloads
// those beyond unloadRadius; each building holds the level its LODGroup shows at its distance
// (plus the next finer one while the camera approaches), the others are released; resident
// textures are kept within textureBudgetMiB where the view allows; at most maxConcurrentLoads
// loads are in flight. Tiles are placed relative to the
// scene's VWorldLodGeoreference (re-placed when its origin moves). Beyond the load radius it shows
// the tileset's HLOD proxies that tiles.json lists (coarse to fine, by screen-space error), so a
// whole city is on screen. The decisions are TileStreamer's and ProxyStreamer's (plain C#, tested
// under mono); this component only feeds them the camera every frame.
using System;
using System.Collections.Generic;
using System.Threading;
using UnityEngine;

namespace VWorldLod
{
    public class VWorldLodStreamer : MonoBehaviour
    {
        /// <summary>tiles.json (or its folder): relative to StreamingAssets, an absolute path, or an http(s) URL.</summary>
        public string tileIndex = TileIndexReader.FileName;
        /// <summary>What the radii are measured from; the main camera when empty.</summary>
        public Transform target;
        /// <summary>Scene units (metres for UR = R): tiles whose centre comes this close are loaded.</summary>
        public float loadRadius = 500;
        /// <summary>Loaded tiles whose centre is further than this are unloaded (at least loadRadius).</summary>
        public float unloadRadius = 650;
        /// <summary>Manifest and glTF loads in flight at once.</summary>
        public int maxConcurrentLoads = 4;
        /// <summary>Show the tileset's merged tile proxies beyond loadRadius (when tiles.json lists them).</summary>
        public bool showProxies = true;
        /// <summary>Pixels: the coarsest proxy whose geometric error looks at most this large is shown (Cesium's default 16).</summary>
        public float maximumScreenSpaceError = 16;
        /// <summary>MiB of textures (levels and proxies) above which what the view does not need is released (Cesium's maximumCachedBytes).</summary>
        public float textureBudgetMiB = 512;
        /// <summary>Bytes per texel as Unity holds the textures: 4 for glTFast's RGBA32 (JPEG/PNG), 1 for BC7/ASTC 4x4 (KTX2), 0.5 for DXT1.</summary>
        public float textureBytesPerPixel = 4;
        /// <summary>Pixels: a building's level is loaded finer than its LODGroup transition when that level's error (error_m, tileset.json's geometricError: 8 x its texel when textured) would look larger; 16 keeps texels within 2 px.</summary>
        public float levelMaximumScreenSpaceError = 16;
        /// <summary>Pixels: a proxy's textures leave out their finest mip levels while its texel (bounded by its error) looks at most this large; 0: whole.</summary>
        public float proxyTextureScreenSpaceError = 2;
        /// <summary>Give every proxy a MeshCollider, so raycasts hit it and BuildingPicking.Resolve names the building under the hit (off: colliders cost memory, a copy of each proxy's triangles).</summary>
        public bool proxyColliders;

        readonly CancellationTokenSource cancel = new CancellationTokenSource();
        TileStreamer streamer;
        ProxyStreamer proxies;
        StreamingSettings settings;

        async void Start()
        {
            try
            {
                await StartStreamingAsync();
            }
            catch (Exception e)
            {
                // async void: anything not caught here would vanish.
                Debug.LogError("VWorld LoD: streaming stopped: " + e.Message);
            }
        }

        async System.Threading.Tasks.Task StartStreamingAsync()
        {
            settings = new StreamingSettings
            {
                LoadRadius = loadRadius, UnloadRadius = unloadRadius, MaxConcurrentLoads = maxConcurrentLoads, MaximumScreenSpaceError = maximumScreenSpaceError,
                TextureBudgetBytes = textureBudgetMiB * 1024.0 * 1024.0, TextureBytesPerPixel = textureBytesPerPixel, LevelMaximumScreenSpaceError = levelMaximumScreenSpaceError,
                ProxyTextureScreenSpaceError = proxyTextureScreenSpaceError,
            };
            if (settings.Problem() != null)
            {
                Debug.LogError("VWorld LoD: " + name + ": " + settings.Problem());
                return;
            }
            string url = StreamingPaths.Resolve(tileIndex, Application.streamingAssetsPath, TileIndexReader.FileName);
            string text;
            try
            {
                text = await WebText.GetAsync(url, cancel.Token);
            }
            catch (Exception e)
            {
                Debug.LogError("VWorld LoD: cannot read the tile index " + e.Message + "; nothing is streamed");
                return;
            }
            if (text == null || cancel.IsCancellationRequested) return;
            var problems = new List<string>();
            TileIndexEntry[] tiles;
            ProxyEntry[] proxyEntries;
            try
            {
                tiles = TileIndexReader.Read(text, url, json => JsonUtility.FromJson<TileIndex>(json), problems, out proxyEntries);
            }
            catch (ManifestException e)
            {
                Debug.LogError("VWorld LoD: " + e.Message + "; nothing is streamed");
                return;
            }
            foreach (string problem in problems) Debug.LogError("VWorld LoD: " + problem);
            if (VWorldLodGeoreference.Current == null)
                Debug.LogWarning("VWorld LoD: no VWorldLodGeoreference in the scene: tiles use the paper's absolute globe placement, where float32 positions jitter by 0.25-0.5 m; add one (GameObject > VWorld LoD > Georeference)");
            streamer = new TileStreamer(tiles, t => t.ScenePosition(VWorldLodGeoreference.CurrentOrigin), settings, new GltfStreamingBackend(transform, url));
            streamer.TilePose = plan => plan.RootPose(VWorldLodGeoreference.CurrentOrigin);
            if (showProxies && proxyEntries.Length > 0)
            {
                proxies = new ProxyStreamer(proxyEntries, p => p.ScenePosition(VWorldLodGeoreference.CurrentOrigin), settings, new GltfProxyBackend(transform, url, streamer.Budget, proxyColliders), streamer.Budget);
                proxies.TileShown = streamer.Shows;
                proxies.TileLoading = streamer.Loading;
                streamer.ProxyShown = proxies.Covers;
            }
            VWorldLodGeoreference.OriginChanged += Reposition;
        }

        void Reposition()
        {
            if (streamer != null) streamer.Reposition();
            if (proxies != null) proxies.Reposition();
        }

        void Update()
        {
            if (streamer == null) return;
            Transform from = target;
            if (from == null && Camera.main != null) from = Camera.main.transform;
            if (from == null) return;
            Vector3 p = from.position;
            // Georeferenced, the radii are horizontal (East/North): a camera high above the city
            // still loads the tiles below it. On the globe (no local up) they are 3D.
            settings.Horizontal = VWorldLodGeoreference.CurrentOrigin != null;
            // Screen sizes need the view: the main camera's (a 60 degree, 1080 px view without one).
            Camera view = Camera.main;
            double height = view != null ? view.pixelHeight : 1080, fov = view != null ? view.fieldOfView : 60;
            streamer.Update(p.x, p.y, p.z, height, fov, QualitySettings.lodBias);
            if (proxies == null) return;
            proxies.Update(p.x, p.y, p.z, height, fov);
        }

        void OnDestroy()
        {
            cancel.Cancel();
            VWorldLodGeoreference.OriginChanged -= Reposition;
            if (streamer != null) streamer.Dispose();
            if (proxies != null) proxies.Dispose();
            streamer = null;
            proxies = null;
        }
    }
}
