// Menu items and the automatic build on import.
//   Tools/VWorld LoD/Build LOD Groups from Manifest…   pick a lod_manifest.json under Assets/
//   Tools/VWorld LoD/Build Automatically on Import      toggle (EditorPrefs, on by default)
// Nothing is built for manifests under Assets/StreamingAssets/ (runtime streaming's folder, shipped
// verbatim in the player).
using System.Collections.Generic;
using System.IO;
using UnityEditor;
using UnityEngine;

namespace VWorldLod.EditorTools
{
    public static class VWorldLodMenu
    {
        public const string ManifestFileName = "lod_manifest.json";
        const string BuildItem = "Tools/VWorld LoD/Build LOD Groups from Manifest\u2026";
        const string AutoItem = "Tools/VWorld LoD/Build Automatically on Import";
        const string AutoKey = "VWorldLod.BuildOnImport";

        /// <summary>Whether importing a lod_manifest.json under Assets/ builds its prefabs.</summary>
        public static bool BuildOnImport
        {
            get { return EditorPrefs.GetBool(AutoKey, true); }
            set { EditorPrefs.SetBool(AutoKey, value); }
        }

        [MenuItem(BuildItem)]
        static void BuildFromManifest()
        {
            string chosen = EditorUtility.OpenFilePanel("Tile manifest (lod_manifest.json)", Application.dataPath, "json");
            if (string.IsNullOrEmpty(chosen)) return;
            string assetPath = ToAssetPath(chosen);
            if (assetPath == null)
            {
                Debug.LogError("VWorld LoD: " + chosen + " is not inside this project's Assets folder; copy the exported tile folder under Assets/ first");
                return;
            }
            LodGroupPrefabBuilder.Build(assetPath);
        }

        [MenuItem(AutoItem)]
        static void ToggleBuildOnImport()
        {
            BuildOnImport = !BuildOnImport;
        }

        [MenuItem(AutoItem, true)]
        static bool ToggleBuildOnImportValidate()
        {
            Menu.SetChecked(AutoItem, BuildOnImport);
            return true;
        }

        /// <summary>Whether an asset path lies under Assets/StreamingAssets/ (shipped verbatim, streamed at run time).</summary>
        public static bool InStreamingAssets(string assetPath)
        {
            return assetPath.Replace('\\', '/').StartsWith("Assets/StreamingAssets/", System.StringComparison.OrdinalIgnoreCase);
        }

        /// <summary>"Assets/..." for an absolute path inside Application.dataPath, else null.</summary>
        public static string ToAssetPath(string absolutePath)
        {
            string full = Path.GetFullPath(absolutePath).Replace('\\', '/');
            string assets = Path.GetFullPath(Application.dataPath).Replace('\\', '/').TrimEnd('/');
            if (full == assets) return "Assets";
            if (!full.StartsWith(assets + "/")) return null;
            return "Assets" + full.Substring(assets.Length);
        }
    }

    /// <summary>
    /// Builds the prefabs of every lod_manifest.json imported under Assets/ (when enabled): skipped
    /// when they are up to date (a Library rebuild, a fresh clone with the prefabs), with background
    /// progress rather than a modal bar.
    /// </summary>
    public class ManifestPostprocessor : AssetPostprocessor
    {
        static readonly List<string> pending = new List<string>();

        static void OnPostprocessAllAssets(string[] importedAssets, string[] deletedAssets, string[] movedAssets, string[] movedFromAssetPaths)
        {
            if (!VWorldLodMenu.BuildOnImport) return;
            foreach (string path in importedAssets)
            {
                if (path.StartsWith("Assets/") && !VWorldLodMenu.InStreamingAssets(path)
                    && Path.GetFileName(path) == VWorldLodMenu.ManifestFileName && !pending.Contains(path))
                    pending.Add(path);
            }
            // Creating prefabs while assets are still importing is not allowed: wait for the editor loop.
            if (pending.Count > 0) EditorApplication.delayCall += BuildPending;
        }

        static void BuildPending()
        {
            EditorApplication.delayCall -= BuildPending;
            string[] paths = pending.ToArray();
            pending.Clear();
            foreach (string path in paths) LodGroupPrefabBuilder.Build(path, BuildTrigger.Automatic);
        }
    }
}
