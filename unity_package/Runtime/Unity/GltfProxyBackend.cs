// The Unity side of ProxyStreamer: each proxy .glb loaded with glTFast (GltfLevelLoader) under a
// root placed like a tile root (VWorldLodTilePlacement at the proxy's centre, relative to the
// scene's georeference and re-placed when its origin moves): the proxy's glTF frame is its tile's
// East/Up/North frame at elevation 0, and glTFast's x flip turns its +X West into Unity's East.
// Its record (tileset_proxies/<tile>.json beside the .glb) is read too: ProxyBuildings on the
// root says which building each vertex came from (picking: BuildingPicking), and with colliders
// on its mesh gets a MeshCollider (memory: a copy of the mesh's triangles in PhysX).
using System.Collections.Generic;
using System.Threading;
using System.Threading.Tasks;
using UnityEngine;

namespace VWorldLod
{
    public class GltfProxyBackend : IProxyBackend
    {
        sealed class Loaded
        {
            public GameObject Root;
            public LoadedLevel Level;
            public List<Texture2D> Capped; // made by ProxyTextureCap: destroyed with the proxy
        }

        readonly Transform parent;
        readonly string indexUrl;
        readonly TextureBudget budget;
        readonly bool colliders;

        /// <summary>
        /// Proxy roots go under parent; files are read beside indexUrl; texture bytes counted as
        /// budget says; colliders: give each proxy's mesh a MeshCollider (for raycasts).
        /// </summary>
        public GltfProxyBackend(Transform parent, string indexUrl, TextureBudget budget, bool colliders)
        {
            this.parent = parent;
            this.indexUrl = indexUrl;
            this.budget = budget;
            this.colliders = colliders;
        }

        public async Task<object> LoadProxy(ProxyEntry proxy, int mipmapLimit, CancellationToken cancellation)
        {
            var root = new GameObject("proxy " + proxy.name);
            root.transform.SetParent(parent, false);
            root.AddComponent<VWorldLodTilePlacement>().Configure(proxy.name, proxy.center.lon, proxy.center.lat, proxy.center.elev, proxy.globe.earth_radius_m, proxy.globe.unity_radius);
            root.GetComponent<VWorldLodTilePlacement>().Place();
            LoadedLevel level = await GltfLevelLoader.LoadAsync(StreamingPaths.Beside(indexUrl, proxy.file), root.transform, proxy.name + "_proxy", cancellation);
            if (level == null)
            {
                Object.Destroy(root);
                return null;
            }
            await AttachBuildings(proxy, root, level, cancellation);
            return new Loaded { Root = root, Level = level, Capped = ProxyTextureCap.Apply(level.Renderers, mipmapLimit) };
        }

        // The proxy's ProxyBuildings from its record, and its MeshCollider when asked. A missing or
        // broken record is reported (naming it) and leaves the proxy shown without picking.
        async Task AttachBuildings(ProxyEntry proxy, GameObject root, LoadedLevel level, CancellationToken cancellation)
        {
            MeshFilter[] meshes = level.Root.GetComponentsInChildren<MeshFilter>(true);
            if (colliders)
                foreach (MeshFilter filter in meshes) filter.gameObject.AddComponent<MeshCollider>().sharedMesh = filter.sharedMesh;
            string url = StreamingPaths.Beside(indexUrl, ProxyFeatures.RecordPath(proxy.file));
            string text;
            try
            {
                text = await WebText.GetAsync(url, cancellation);
            }
            catch (System.Exception e)
            {
                if (!cancellation.IsCancellationRequested) Report(e.Message + ": the proxy's buildings cannot be picked");
                return;
            }
            if (text == null || cancellation.IsCancellationRequested) return;
            if (meshes.Length != 1 || meshes[0].sharedMesh == null)
            {
                Report(url + ": the proxy has " + meshes.Length + " meshes, its record describes one: its buildings cannot be picked");
                return;
            }
            try
            {
                ProxyBuildings.Attach(root, proxy.name, ProxyFeatures.Parse(text, url, meshes[0].sharedMesh.vertexCount));
            }
            catch (ManifestException e)
            {
                Report(e.Message + ": the proxy's buildings cannot be picked");
            }
        }

        public void ShowProxy(object loaded, bool visible)
        {
            ((Loaded)loaded).Level.Root.SetActive(visible);
        }

        /// <summary>The proxy's distinct textures (every texture property of its renderers' materials), as the budget counts texels.</summary>
        public long TextureBytes(object loaded)
        {
            var seen = new HashSet<Texture>();
            long bytes = 0;
            foreach (Renderer renderer in ((Loaded)loaded).Level.Renderers)
                foreach (Material material in renderer.sharedMaterials)
                {
                    if (material == null) continue;
                    foreach (string property in material.GetTexturePropertyNames())
                    {
                        Texture texture = material.GetTexture(property);
                        if (texture != null && seen.Add(texture)) bytes += budget.Bytes(texture.width, texture.height);
                    }
                }
            return bytes;
        }

        public void ReleaseProxy(object loaded)
        {
            var proxy = (Loaded)loaded;
            proxy.Level.Release();
            foreach (Texture2D texture in proxy.Capped) Object.Destroy(texture);
            if (proxy.Root != null) Object.Destroy(proxy.Root);
        }

        public void Report(string message)
        {
            Debug.LogError("VWorld LoD: " + message);
        }
    }
}
