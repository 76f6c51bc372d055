// Loads one exported tile at play time: reads lod_manifest.json (from StreamingAssets, an
// absolute path or an http(s) URL), plans it with the same code as the Editor importer
// (LodPlanner), loads every LoD's glTF through glTFast (GltfLevelLoader: messages in the console
// naming the file) and builds one LODGroup per building under a tile root placed relative to the
// scene's georeference (VWorldLodTilePlacement). For many tiles around a moving camera use
// VWorldLodStreamer instead.
//
// Meshes loaded this way are not assets: they live as long as this component and cannot be saved
// into prefabs; use the Editor importer for that. Destroying the component cancels loads in
// flight (each cleans up after itself, without exceptions) and frees what was loaded.
using System;
using System.Collections.Generic;
using System.Threading;
using System.Threading.Tasks;
using UnityEngine;

namespace VWorldLod
{
    public class VWorldLodTileLoader : MonoBehaviour
    {
        /// <summary>A lod_manifest.json: relative to StreamingAssets, an absolute path, or an http(s) URL.</summary>
        public string manifestPath = "";
        public bool loadOnStart = true;

        readonly CancellationTokenSource cancel = new CancellationTokenSource();
        readonly List<LoadedLevel> loaded = new List<LoadedLevel>();

        async void Start()
        {
            if (!loadOnStart) return;
            try
            {
                await LoadAsync();
            }
            catch (Exception e)
            {
                // async void: anything not caught here would vanish.
                Debug.LogError("VWorld LoD: " + manifestPath + ": " + e.Message);
            }
        }

        /// <summary>Builds the tile under this GameObject; returns its plan (failures included), or null when the manifest is unusable or loading was cancelled.</summary>
        public async Task<TilePlan> LoadAsync()
        {
            string url = StreamingPaths.Resolve(manifestPath, Application.streamingAssetsPath, "lod_manifest.json");
            CancellationToken token = cancel.Token;
            TilePlan plan;
            try
            {
                plan = await RuntimeTile.LoadPlanAsync(url, token);
                if (plan == null || token.IsCancellationRequested) return null;
            }
            catch (Exception e)
            {
                Debug.LogError(RuntimeTile.Describe(e, url));
                return null;
            }
            GameObject tileRoot = RuntimeTile.CreateRoot(plan, transform);
            LodGroupAssembly.WarnAboutFade(plan);

            int built = 0;
            foreach (BuildingPlan building in plan.Buildings)
            {
                if (await BuildBuildingAsync(plan, building, tileRoot.transform, token)) built++;
                if (token.IsCancellationRequested) return null;
            }
            Debug.Log("VWorld LoD: " + url + ": built " + built + " of " + (plan.Buildings.Length + plan.Failures.Length) + " buildings");
            return plan;
        }

        // One LODGroup under tileRoot; false (and nothing left behind) when a level does not load.
        async Task<bool> BuildBuildingAsync(TilePlan plan, BuildingPlan building, Transform tileRoot, CancellationToken token)
        {
            var root = new GameObject(building.Name);
            root.transform.SetParent(tileRoot, false);
            LodGroupAssembly.ApplyPlacement(root.transform, building.Relative);
            var levels = new List<LoadedLevel>();
            for (int k = 0; k < building.Levels.Length; k++)
            {
                LoadedLevel level = await GltfLevelLoader.LoadAsync(building.Levels[k].Path, root.transform, building.Name + "_LOD" + k, token);
                if (level == null)
                {
                    foreach (LoadedLevel l in levels) l.Release();
                    Destroy(root);
                    return false;
                }
                if (token.IsCancellationRequested)
                {
                    // Destroyed while this level finished: nobody else will free it.
                    level.Release();
                    foreach (LoadedLevel l in levels) l.Release();
                    return false;
                }
                levels.Add(level);
            }
            loaded.AddRange(levels);
            LodGroupAssembly.ConfigureLoaded(root, building, plan, LodGroupAssembly.AllLevels(building), levels);
            return true;
        }

        void OnDestroy()
        {
            cancel.Cancel();
            foreach (LoadedLevel level in loaded) level.Release();
            loaded.Clear();
        }
    }
}
