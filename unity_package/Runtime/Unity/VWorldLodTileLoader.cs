// Loads one exported tile at play time: reads lod_manifest.json from the local file system,
// plans it with the same code as the Editor importer (LodPlanner), loads every LoD's glTF
// through glTFast and builds one LODGroup per building under a tile root.
//
// Meshes loaded this way are not assets: they live as long as this component (its GltfImports
// are disposed in OnDestroy) and cannot be saved into prefabs; use the Editor importer for that.
using System;
using System.Collections.Generic;
using System.IO;
using System.Threading.Tasks;
using GLTFast;
using UnityEngine;

namespace VWorldLod
{
    public class VWorldLodTileLoader : MonoBehaviour
    {
        /// <summary>Path of a lod_manifest.json; relative paths are under StreamingAssets.</summary>
        public string manifestPath = "";
        public bool loadOnStart = true;

        readonly List<GltfImport> imports = new List<GltfImport>();

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
                Debug.LogException(e);
            }
        }

        /// <summary>Builds the tile under this GameObject; returns its plan (failures included).</summary>
        public async Task<TilePlan> LoadAsync()
        {
            string path = Path.IsPathRooted(manifestPath) ? manifestPath : Path.Combine(Application.streamingAssetsPath, manifestPath);
            TilePlan plan = LodPlanner.Load(path, new JsonUtilityManifestParser(), File.Exists);
            foreach (ManifestException failure in plan.Failures)
                Debug.LogError(failure.Message);

            var tileRoot = new GameObject(plan.TileName);
            tileRoot.transform.SetParent(transform, false);
            LodGroupAssembly.ApplyPlacement(tileRoot.transform, plan.TileRoot);

            int built = 0;
            foreach (BuildingPlan building in plan.Buildings)
            {
                try
                {
                    if (await BuildBuildingAsync(plan, building, tileRoot.transform)) built++;
                }
                catch (Exception e)
                {
                    // One building's failure (I/O, a glTF glTFast rejects) must not stop the tile.
                    Debug.LogError(plan.ManifestPath + ": building " + building.Id + ": " + e.Message);
                }
            }
            Debug.Log(plan.ManifestPath + ": built " + built + " of " + (plan.Buildings.Length + plan.Failures.Length) + " buildings");
            return plan;
        }

        // One LODGroup under tileRoot; false (and nothing left behind) when a level does not load.
        async Task<bool> BuildBuildingAsync(TilePlan plan, BuildingPlan building, Transform tileRoot)
        {
            var root = new GameObject(building.Name);
            root.transform.SetParent(tileRoot, false);
            LodGroupAssembly.ApplyPlacement(root.transform, building.Local);
            var renderers = new Renderer[building.Levels.Length][];
            try
            {
                for (int k = 0; k < building.Levels.Length; k++)
                {
                    var level = new GameObject(building.Name + "_LOD" + k);
                    level.transform.SetParent(root.transform, false);
                    var gltf = new GltfImport();
                    imports.Add(gltf);
                    bool ok = await gltf.Load(new Uri(Path.GetFullPath(building.Levels[k].Path)))
                              && await gltf.InstantiateMainSceneAsync(level.transform);
                    if (!ok)
                    {
                        Debug.LogError(plan.ManifestPath + ": building " + building.Id + ": glTFast could not load " + building.Levels[k].Path);
                        Destroy(root);
                        return false;
                    }
                    renderers[k] = level.GetComponentsInChildren<Renderer>();
                }
            }
            catch
            {
                Destroy(root);
                throw;
            }
            LodGroupAssembly.Configure(root, building, plan, renderers);
            return true;
        }

        void OnDestroy()
        {
            foreach (GltfImport gltf in imports) gltf.Dispose();
            imports.Clear();
        }
    }
}
