// Editor import of one tile manifest under Assets/: one prefab per building (a LODGroup over the
// imported glTF levels) and one tile prefab holding every building at its placement.
//
// Flat pipeline: plan (LodPlanner) -> up-to-date check (BuildStamp; automatic builds only) ->
// make sure every glTF is imported -> each level's embedded images written out as texture files
// that Unity compresses per platform (TextureFiles, TextureImportPostprocessor) and materials
// using them (LevelMaterials) -> building prefabs (in one StartAssetEditing batch) -> tile prefab
// (after the batch, so the building prefabs load) -> the build's hash recorded.
// Prefabs go to <manifest folder>/Prefabs/<building>.prefab and <tile>.prefab: re-running
// overwrites them in place (same paths, same GUIDs), so scene instances update and nothing is
// duplicated.
using System;
using System.Collections.Generic;
using System.IO;
using UnityEditor;
using UnityEngine;

namespace VWorldLod.EditorTools
{
    /// <summary>What a build did, for the console summary.</summary>
    public class BuildReport
    {
        public string ManifestPath;
        public int Built;
        public int Failed;
        public bool Cancelled;
        public bool UpToDate;
        public string TilePrefabPath;

        public override string ToString()
        {
            if (UpToDate) return "VWorld LoD: " + ManifestPath + ": prefabs up to date";
            return "VWorld LoD: " + ManifestPath + ": " + Built + " building prefab(s) built, " + Failed + " failed"
                   + (Cancelled ? ", cancelled" : "")
                   + (string.IsNullOrEmpty(TilePrefabPath) ? "" : "; tile prefab " + TilePrefabPath);
        }
    }

    public static class LodGroupPrefabBuilder
    {
        /// <summary>Builds the prefabs of the manifest at manifestAssetPath ("Assets/.../lod_manifest.json"), as the menu does.</summary>
        public static BuildReport Build(string manifestAssetPath)
        {
            return Build(manifestAssetPath, BuildTrigger.Menu);
        }

        /// <summary>
        /// Builds the prefabs of the manifest at manifestAssetPath; an automatic build is skipped
        /// when they are up to date and shows no modal dialog (BuildProgress).
        /// </summary>
        public static BuildReport Build(string manifestAssetPath, BuildTrigger trigger)
        {
            var report = new BuildReport { ManifestPath = manifestAssetPath };
            if (VWorldLodMenu.InStreamingAssets(manifestAssetPath))
            {
                // StreamingAssets ships verbatim in the player: prefabs written there would ship too.
                Debug.LogError("VWorld LoD: " + manifestAssetPath + " is under StreamingAssets, which is for runtime streaming (VWorldLodStreamer); no prefabs are built there. Copy the tile folder elsewhere under Assets/ to build prefabs.");
                report.Failed = 1;
                return report;
            }
            TilePlan plan;
            try
            {
                plan = LodPlanner.Load(manifestAssetPath, new JsonUtilityManifestParser(), File.Exists);
            }
            catch (ManifestException e)
            {
                Debug.LogError(e.Message);
                report.Failed = 1;
                return report;
            }
            foreach (ManifestException failure in plan.Failures)
                Debug.LogError(failure.Message);
            string prefabFolder = plan.Folder + "/Prefabs";
            string hash = null;
            try
            {
                hash = BuildStamp.Hash(plan);
            }
            catch (IOException e)
            {
                Debug.LogWarning(manifestAssetPath + ": cannot hash its files for the up-to-date check (" + e.Message + "); rebuilding");
            }
            if (hash != null && BuildProgress.SkipsWhenUpToDate(trigger) && plan.Failures.Length == 0 && BuildStamp.IsUpToDate(plan, prefabFolder, File.Exists, hash))
            {
                report.UpToDate = true;
                return report;
            }
            LodGroupAssembly.WarnAboutFade(plan);
            report.Failed = plan.Failures.Length;

            EnsureFolder(plan.Folder, "Prefabs");
            BuildStamp.Clear(prefabFolder);
            var levelAssets = LoadLevelAssets(plan, report);
            var materials = CompressedMaterials(plan, levelAssets, prefabFolder);
            var saved = new List<BuildingPlan>();
            IBuildProgress progress = BuildProgress.For(trigger, manifestAssetPath);
            try
            {
                AssetDatabase.StartAssetEditing();
                for (int i = 0; i < plan.Buildings.Length; i++)
                {
                    BuildingPlan building = plan.Buildings[i];
                    if (progress.Step(building.Id, (float)i / plan.Buildings.Length))
                    {
                        report.Cancelled = true;
                        break;
                    }
                    GameObject[] levels;
                    if (!levelAssets.TryGetValue(building.Id, out levels)) continue;
                    Dictionary<Material, Material>[] levelMaterials;
                    materials.TryGetValue(building.Id, out levelMaterials);
                    if (SaveBuildingPrefab(building, plan, levels, levelMaterials, prefabFolder + "/" + building.Name + ".prefab"))
                    {
                        saved.Add(building);
                        report.Built++;
                    }
                    else
                    {
                        report.Failed++;
                    }
                }
            }
            finally
            {
                AssetDatabase.StopAssetEditing();
                progress.Done(!report.Cancelled && report.Failed == 0);
            }

            if (!report.Cancelled)
                report.TilePrefabPath = SaveTilePrefab(plan, saved, prefabFolder);
            if (hash != null && !report.Cancelled && report.Failed == 0 && report.TilePrefabPath != null)
                BuildStamp.Record(prefabFolder, hash);
            Debug.Log(report.ToString());
            return report;
        }

        // Per building id, per level: glTFast's material -> one using the level's images as texture
        // files that Unity compresses (written and imported first, so TextureImportPostprocessor
        // gives them their settings). A building whose .glb images cannot be read keeps glTFast's
        // textures (console warning).
        static Dictionary<string, Dictionary<Material, Material>[]> CompressedMaterials(
            TilePlan plan, Dictionary<string, GameObject[]> levelAssets, string prefabFolder)
        {
            var textures = new Dictionary<string, Dictionary<string, string>[]>();
            var written = new List<string>();
            string textureFolder = EnsureFolder(plan.Folder, TextureFiles.FolderName);
            foreach (BuildingPlan building in plan.Buildings)
            {
                if (!levelAssets.ContainsKey(building.Id)) continue;
                try
                {
                    EnsureFolder(textureFolder, building.Name);
                    textures[building.Id] = TextureFiles.Extract(building, plan.Folder, written);
                }
                catch (Exception e)
                {
                    Debug.LogWarning(plan.ManifestPath + ": building " + building.Id + ": its textures stay uncompressed: " + e.Message);
                }
            }
            foreach (string path in written)
                AssetDatabase.ImportAsset(path, ImportAssetOptions.ForceSynchronousImport);

            var result = new Dictionary<string, Dictionary<Material, Material>[]>();
            string materialFolder = EnsureFolder(prefabFolder, "Materials");
            foreach (KeyValuePair<string, Dictionary<string, string>[]> entry in textures)
            {
                BuildingPlan building = Array.Find(plan.Buildings, b => b.Id == entry.Key);
                result[entry.Key] = LevelMaterials.Make(building, levelAssets[entry.Key], entry.Value, EnsureFolder(materialFolder, building.Name));
            }
            return result;
        }

        // Every level's imported glTF, per building id; a building with a level that is not
        // (and cannot be) imported is reported and left out.
        static Dictionary<string, GameObject[]> LoadLevelAssets(TilePlan plan, BuildReport report)
        {
            var result = new Dictionary<string, GameObject[]>();
            foreach (BuildingPlan building in plan.Buildings)
            {
                var levels = new GameObject[building.Levels.Length];
                for (int k = 0; k < levels.Length; k++)
                {
                    string path = building.Levels[k].Path;
                    levels[k] = AssetDatabase.LoadAssetAtPath<GameObject>(path);
                    if (levels[k] == null)
                    {
                        AssetDatabase.ImportAsset(path, ImportAssetOptions.ForceSynchronousImport);
                        levels[k] = AssetDatabase.LoadAssetAtPath<GameObject>(path);
                    }
                    if (levels[k] == null)
                    {
                        Debug.LogError(plan.ManifestPath + ": building " + building.Id + ": " + path
                                       + " did not import as a model (is glTFast, com.unity.cloud.gltfast, installed?)");
                        report.Failed++;
                        levels = null;
                        break;
                    }
                }
                if (levels != null) result[building.Id] = levels;
            }
            return result;
        }

        static bool SaveBuildingPrefab(BuildingPlan building, TilePlan plan, GameObject[] levelAssets,
                                       Dictionary<Material, Material>[] materials, string prefabPath)
        {
            var root = new GameObject(building.Name);
            try
            {
                var levels = new GameObject[levelAssets.Length];
                var renderers = new Renderer[levelAssets.Length][];
                for (int k = 0; k < levelAssets.Length; k++)
                {
                    levels[k] = (GameObject)PrefabUtility.InstantiatePrefab(levelAssets[k], root.transform);
                    levels[k].name = building.Name + "_LOD" + k;
                    renderers[k] = levels[k].GetComponentsInChildren<Renderer>();
                    if (materials != null) LevelMaterials.Apply(renderers[k], materials[k]);
                }
                LodGroupAssembly.Configure(root, building, plan, levels, renderers);
                bool ok;
                PrefabUtility.SaveAsPrefabAsset(root, prefabPath, out ok);
                if (!ok) Debug.LogError(plan.ManifestPath + ": building " + building.Id + ": could not save " + prefabPath);
                return ok;
            }
            catch (Exception e)
            {
                Debug.LogError(plan.ManifestPath + ": building " + building.Id + ": " + e.Message);
                return false;
            }
            finally
            {
                UnityEngine.Object.DestroyImmediate(root);
            }
        }

        static string SaveTilePrefab(TilePlan plan, List<BuildingPlan> buildings, string prefabFolder)
        {
            var root = new GameObject(plan.TileName);
            try
            {
                // The root keeps its manifest placement relative to the scene's georeference
                // wherever the prefab is dropped (VWorldLodTilePlacement); buildings sit at their
                // relative_placement under it.
                root.AddComponent<VWorldLodTilePlacement>().Configure(plan);
                root.GetComponent<VWorldLodTilePlacement>().Place();
                foreach (BuildingPlan building in buildings)
                {
                    var prefab = AssetDatabase.LoadAssetAtPath<GameObject>(prefabFolder + "/" + building.Name + ".prefab");
                    if (prefab == null) continue;
                    var instance = (GameObject)PrefabUtility.InstantiatePrefab(prefab, root.transform);
                    LodGroupAssembly.ApplyPlacement(instance.transform, building.Relative);
                }
                string path = prefabFolder + "/" + plan.TileName + ".prefab";
                bool ok;
                PrefabUtility.SaveAsPrefabAsset(root, path, out ok);
                if (!ok)
                {
                    Debug.LogError(plan.ManifestPath + ": could not save the tile prefab " + path);
                    return null;
                }
                return path;
            }
            finally
            {
                UnityEngine.Object.DestroyImmediate(root);
            }
        }

        static string EnsureFolder(string parent, string name)
        {
            string path = parent + "/" + name;
            if (!AssetDatabase.IsValidFolder(path)) AssetDatabase.CreateFolder(parent, name);
            return path;
        }
    }
}
