// Stand-in for UnityEditor: exactly the members unity_package's Editor scripts use, with Unity's
// signatures (Unity 2022.3 and 6000.0; base classes the package never names are left out). Bodies
// throw: nothing here runs outside the Unity Editor.
using System;
using UnityEngine;

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
    }

    public sealed class PrefabUtility
    {
        public static UnityEngine.Object InstantiatePrefab(UnityEngine.Object assetComponentOrGameObject, Transform parent) { throw new NotSupportedException("stand-in"); }
        public static GameObject SaveAsPrefabAsset(GameObject instanceRoot, string assetPath, out bool success) { throw new NotSupportedException("stand-in"); }
    }

    public class AssetPostprocessor { }
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
