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
            LodGroupAssembly.ApplyPose(tileRoot.transform, plan.TileRoot);

            int built = 0;
            foreach (BuildingPlan building in plan.Buildings)
            {
                var root = new GameObject(building.Name);
                root.transform.SetParent(tileRoot.transform, false);
                LodGroupAssembly.ApplyPose(root.transform, building.Local);
                var renderers = new Renderer[building.Levels.Length][];
                bool ok = true;
                for (int k = 0; k < building.Levels.Length && ok; k++)
                {
                    var level = new GameObject("LOD" + k);
                    level.transform.SetParent(root.transform, false);
                    var gltf = new GltfImport();
                    imports.Add(gltf);
                    ok = await gltf.Load(new Uri(Path.GetFullPath(building.Levels[k].Path)))
                         && await gltf.InstantiateMainSceneAsync(level.transform);
                    renderers[k] = level.GetComponentsInChildren<Renderer>();
                    if (!ok) Debug.LogError(plan.ManifestPath + ": building " + building.Id + ": glTFast could not load " + building.Levels[k].Path);
                }
                if (!ok)
                {
                    Destroy(root);
                    continue;
                }
                LodGroupAssembly.Configure(root, building, plan, renderers);
                built++;
            }
            Debug.Log(plan.ManifestPath + ": built " + built + " of " + (plan.Buildings.Length + plan.Failures.Length) + " buildings");
            return plan;
        }

        void OnDestroy()
        {
            foreach (GltfImport gltf in imports) gltf.Dispose();
            imports.Clear();
        }
    }
}
