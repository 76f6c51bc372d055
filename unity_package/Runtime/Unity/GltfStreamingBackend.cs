// The Unity side of TileStreamer: manifests read with UnityWebRequest and planned with
// LodPlanner, tile roots placed by VWorldLodTilePlacement (relative to the scene's
// georeference), levels loaded with glTFast (GltfLevelLoader) and shown through one LODGroup per
// building that holds the levels resident now (LodGroupAssembly.ConfigureLoaded), which
// TileStreamer picks by screen size and releases when no longer needed.
using System;
using System.Collections.Generic;
using System.Threading;
using System.Threading.Tasks;
using UnityEngine;

namespace VWorldLod
{
    public class GltfStreamingBackend : IStreamingBackend
    {
        readonly Transform parent;
        readonly string indexUrl;
        readonly Dictionary<TilePlan, GameObject> tileRoots = new Dictionary<TilePlan, GameObject>();
        readonly Dictionary<BuildingPlan, GameObject> buildingRoots = new Dictionary<BuildingPlan, GameObject>();
        bool fadeWarned;

        /// <summary>Tile roots go under parent; manifests are read beside indexUrl.</summary>
        public GltfStreamingBackend(Transform parent, string indexUrl)
        {
            this.parent = parent;
            this.indexUrl = indexUrl;
        }

        public async Task<TilePlan> LoadTile(TileIndexEntry tile, CancellationToken cancellation)
        {
            string url = StreamingPaths.Beside(indexUrl, tile.manifest);
            try
            {
                TilePlan plan = await RuntimeTile.LoadPlanAsync(url, cancellation);
                if (plan == null || cancellation.IsCancellationRequested) return null;
                tileRoots[plan] = RuntimeTile.CreateRoot(plan, parent);
                if (!fadeWarned) fadeWarned = LodGroupAssembly.WarnAboutFade(plan);
                return plan;
            }
            catch (Exception e)
            {
                if (!cancellation.IsCancellationRequested) Debug.LogError(RuntimeTile.Describe(e, url));
            }
            return null;
        }

        public async Task<object> LoadLevel(TilePlan tile, BuildingPlan building, int level, CancellationToken cancellation)
        {
            GameObject tileRoot;
            if (!tileRoots.TryGetValue(tile, out tileRoot) || tileRoot == null) return null;
            GameObject root;
            if (!buildingRoots.TryGetValue(building, out root) || root == null)
            {
                root = new GameObject(building.Name);
                root.transform.SetParent(tileRoot.transform, false);
                LodGroupAssembly.ApplyPlacement(root.transform, building.Relative);
                buildingRoots[building] = root;
            }
            return await GltfLevelLoader.LoadAsync(building.Levels[level].Path, root.transform, building.Name + "_LOD" + level, cancellation);
        }

        public void ShowLevels(TilePlan tile, BuildingPlan building, int[] levels, object[] loaded)
        {
            GameObject root;
            // Nothing resident (the building culled at its distance): its released levels' objects
            // are gone already, and a LODGroup cannot be given zero levels.
            if (!buildingRoots.TryGetValue(building, out root) || root == null || levels.Length == 0) return;
            LodGroupAssembly.ConfigureLoaded(root, building, tile, levels, Array.ConvertAll(loaded, level => (LoadedLevel)level));
        }

        public void ReleaseLevel(object loaded)
        {
            ((LoadedLevel)loaded).Release();
        }

        public void UnloadTile(TilePlan tile)
        {
            GameObject root;
            if (tileRoots.TryGetValue(tile, out root) && root != null) UnityEngine.Object.Destroy(root);
            tileRoots.Remove(tile);
            foreach (BuildingPlan building in tile.Buildings) buildingRoots.Remove(building);
        }

        public void Report(string message)
        {
            Debug.LogError("VWorld LoD: " + message);
        }
    }
}
