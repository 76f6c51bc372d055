// Stand-in for UnityEngine: declares exactly the members unity_package uses, with Unity's
// namespaces, type names and signatures (Unity 2022.3 scripting API), so the package's scripts
// compile under mono. Bodies are minimal: they record values (properties) or throw (engine calls
// that need a running player); tests run only the package's plain logic.
using System;

namespace UnityEngine
{
    public class Object
    {
        public string name { get; set; }
        public static void Destroy(Object obj) { throw new NotSupportedException("stand-in"); }
        public static void DestroyImmediate(Object obj) { throw new NotSupportedException("stand-in"); }
    }

    public class Component : Object
    {
        public Transform transform { get { throw new NotSupportedException("stand-in"); } }
    }

    public class Behaviour : Component { }

    public class MonoBehaviour : Behaviour { }

    public class Transform : Component
    {
        public Vector3 localPosition { get; set; }
        public Quaternion localRotation { get; set; }
        public Vector3 localScale { get; set; }
        public void SetParent(Transform parent, bool worldPositionStays) { throw new NotSupportedException("stand-in"); }
    }

    public class Renderer : Component { }

    public sealed class GameObject : Object
    {
        public GameObject(string name) { this.name = name; }
        public Transform transform { get { throw new NotSupportedException("stand-in"); } }
        public T GetComponent<T>() { throw new NotSupportedException("stand-in"); }
        public T AddComponent<T>() where T : Component { throw new NotSupportedException("stand-in"); }
        public T[] GetComponentsInChildren<T>() { throw new NotSupportedException("stand-in"); }
    }

    public struct Vector3
    {
        public Vector3(float x, float y, float z) { }
    }

    public struct Quaternion
    {
        public Quaternion(float x, float y, float z, float w) { }
    }

    public enum LODFadeMode
    {
        None = 0,
        CrossFade = 1,
        SpeedTree = 2,
    }

    public struct LOD
    {
        public float fadeTransitionWidth;

        public LOD(float screenRelativeTransitionHeight, Renderer[] renderers)
        {
            fadeTransitionWidth = 0f;
        }
    }

    public class LODGroup : Component
    {
        public LODFadeMode fadeMode { get; set; }
        public bool animateCrossFading { get; set; }
        public void SetLODs(LOD[] lods) { throw new NotSupportedException("stand-in"); }
        public void RecalculateBounds() { throw new NotSupportedException("stand-in"); }
    }

    public static class Debug
    {
        public static void Log(object message) { Console.WriteLine(message); }
        public static void LogError(object message) { Console.Error.WriteLine(message); }
        public static void LogException(Exception exception) { Console.Error.WriteLine(exception); }
    }

    public static class JsonUtility
    {
        public static T FromJson<T>(string json) { throw new NotSupportedException("stand-in: JsonUtility needs the Unity runtime"); }
    }

    public class Application
    {
        public static string dataPath { get { throw new NotSupportedException("stand-in"); } }
        public static string streamingAssetsPath { get { throw new NotSupportedException("stand-in"); } }
    }
}
