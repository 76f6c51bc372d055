// Stand-in for UnityEditor: exactly the members unity_package's Editor scripts use, with Unity's
// signatures (Unity 2022.3 and 6000.0; base classes the package never names are left out). Bodies
// throw: nothing here runs outside the Unity Editor.
using System;
using UnityEngine;

[assembly: System.Runtime.CompilerServices.InternalsVisibleTo("VWorldLod.Tests")]

namespace UnityEditor
{
    [AttributeUsage(AttributeTargets.Method, AllowMultiple = true)]
    public sealed class MenuItem : Attribute
    {
        public MenuItem(string itemName) { }
        public MenuItem(string itemName, bool isValidateFunction) { }
        public MenuItem(string itemName, bool isValidateFunction, int priority) { }
    }

    public sealed class Menu
    {
        public static void SetChecked(string menuPath, bool isChecked) { throw new NotSupportedException("stand-in"); }
    }

    public sealed class EditorPrefs
    {
        public static bool GetBool(string key, bool defaultValue) { throw new NotSupportedException("stand-in"); }
        public static void SetBool(string key, bool value) { throw new NotSupportedException("stand-in"); }
    }

    public sealed class EditorApplication
    {
        public delegate void CallbackFunction();
        public static CallbackFunction delayCall;
        public static event Action hierarchyChanged { add { } remove { } }
        public static bool isPlayingOrWillChangePlaymode { get { throw new NotSupportedException("stand-in"); } }
    }

    [AttributeUsage(AttributeTargets.Class)]
    public sealed class InitializeOnLoad : Attribute { }

    public sealed class Undo
    {
        public static void RegisterCreatedObjectUndo(UnityEngine.Object objectToUndo, string name) { throw new NotSupportedException("stand-in"); }
    }

    public sealed class Selection
    {
        public static GameObject activeGameObject { get; set; }
    }

    public sealed class EditorUtility
    {
        public static bool DisplayCancelableProgressBar(string title, string info, float progress) { throw new NotSupportedException("stand-in"); }
        public static void ClearProgressBar() { throw new NotSupportedException("stand-in"); }
        public static string OpenFilePanel(string title, string directory, string extension) { throw new NotSupportedException("stand-in"); }
        public static void CopySerialized(UnityEngine.Object source, UnityEngine.Object dest) { throw new NotSupportedException("stand-in"); }
        public static void SetDirty(UnityEngine.Object target) { throw new NotSupportedException("stand-in"); }
    }

    [Flags]
    public enum ImportAssetOptions
    {
        ForceSynchronousImport = 8,
    }

    public sealed class AssetDatabase
    {
        public static T LoadAssetAtPath<T>(string assetPath) where T : UnityEngine.Object { throw new NotSupportedException("stand-in"); }
        public static void ImportAsset(string path, ImportAssetOptions options) { throw new NotSupportedException("stand-in"); }
        public static void StartAssetEditing() { throw new NotSupportedException("stand-in"); }
        public static void StopAssetEditing() { throw new NotSupportedException("stand-in"); }
        public static bool IsValidFolder(string path) { throw new NotSupportedException("stand-in"); }
        public static string CreateFolder(string parentFolder, string newFolderName) { throw new NotSupportedException("stand-in"); }
        public static void CreateAsset(UnityEngine.Object asset, string path) { throw new NotSupportedException("stand-in"); }
    }

    public sealed class PrefabUtility
    {
        public static UnityEngine.Object InstantiatePrefab(UnityEngine.Object assetComponentOrGameObject, Transform parent) { throw new NotSupportedException("stand-in"); }
        public static GameObject SaveAsPrefabAsset(GameObject instanceRoot, string assetPath, out bool success) { throw new NotSupportedException("stand-in"); }
    }

    // Real: assetPath has a setter too; assetImporter is AssetImporter.GetAtPath(assetPath) (here
    // whatever the tests put in `importer`).
    public class AssetPostprocessor
    {
        internal AssetImporter importer;
        public string assetPath { get; set; }
        public AssetImporter assetImporter { get { return importer; } }
    }

    // Real: AssetImporter : Object (native). The tests set importSettingsMissing through `missing`.
    public class AssetImporter : UnityEngine.Object
    {
        internal bool missing = true;
        public bool importSettingsMissing { get { return missing; } }
        public string userData { get; set; }
    }

    // Real: TextureImporter : AssetImporter, every property native (extern get; set;). The stand-in
    // keeps what it is given, so the tests read back what the package applied.
    public sealed class TextureImporter : AssetImporter
    {
        public TextureImporterType textureType { get; set; }
        public bool sRGBTexture { get; set; }
        public TextureImporterAlphaSource alphaSource { get; set; }
        public bool mipmapEnabled { get; set; }
        public bool streamingMipmaps { get; set; }
        public TextureImporterNPOTScale npotScale { get; set; }
        public bool isReadable { get; set; }
        public TextureWrapMode wrapMode { get; set; }
        public FilterMode filterMode { get; set; }
        public int maxTextureSize { get; set; }
        public TextureImporterCompression textureCompression { get; set; }
        internal readonly System.Collections.Generic.List<TextureImporterPlatformSettings> platforms = new System.Collections.Generic.List<TextureImporterPlatformSettings>();
        public void SetPlatformTextureSettings(TextureImporterPlatformSettings platformSettings) { platforms.Add(platformSettings); }
    }

    // Real: a sealed class whose properties are backed by a native struct.
    public sealed class TextureImporterPlatformSettings
    {
        public string name { get; set; }
        public bool overridden { get; set; }
        public int maxTextureSize { get; set; }
        public TextureImporterFormat format { get; set; }
        public TextureImporterCompression textureCompression { get; set; }
    }

    // Values as in UnityCsReference (2022.3 and 6000.x) Editor/Mono/AssetPipeline/TextureImporterEnums.cs.
    public enum TextureImporterType
    {
        Default = 0,
    }

    public enum TextureImporterAlphaSource
    {
        None = 0,
        FromInput = 1,
    }

    public enum TextureImporterNPOTScale
    {
        None = 0,
    }

    public enum TextureImporterCompression
    {
        Compressed = 1,
    }

    public enum TextureImporterFormat
    {
        RGBA32 = 4,
        DXT1 = 10,
        DXT5 = 12,
        BC7 = 25,
        ASTC_6x6 = 50,
    }

    // Real: Progress (Editor/Mono/Progress/Progress.bindings.cs), Unity 2020.1 on. The stand-in logs
    // its calls in `calls` for the tests.
    public static class Progress
    {
        public enum Status
        {
            Running,
            Succeeded,
            Failed,
            Canceled,
            Paused,
        }

        [Flags]
        public enum Options
        {
            None = 0,
        }

        internal static readonly System.Collections.Generic.List<string> calls = new System.Collections.Generic.List<string>();
        public static int Start(string name, string description = null, Options options = Options.None, int parentId = -1) { calls.Add("Start " + name); return calls.Count; }
        public static void Report(int id, float progress, string description) { calls.Add("Report " + progress + " " + description); }
        public static void Finish(int id, Status status = Status.Succeeded) { calls.Add("Finish " + status); }
    }
}

namespace UnityEditor.SceneManagement
{
    // Real: PrefabStage : PreviewSceneStage : Stage : ScriptableObject; EditorSceneManager : SceneManager.
    public sealed class PrefabStage { }

    public static class PrefabStageUtility
    {
        public static PrefabStage GetPrefabStage(GameObject gameObject) { throw new NotSupportedException("stand-in"); }
    }

    public sealed class EditorSceneManager
    {
        public static bool IsPreviewSceneObject(UnityEngine.Object obj) { throw new NotSupportedException("stand-in"); }
    }
}
