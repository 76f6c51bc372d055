// Stand-in for UnityEngine: declares exactly the members unity_package uses, with Unity's
// namespaces, type names and signatures (Unity 2022.3 scripting API), so the package's scripts
// compile under mono. Bodies are minimal: GameObject keeps its components, LODGroup and the
// Transform's properties record what they are given (in non-public fields, which the C# tests
// read by reflection), and engine calls that need a running player throw.
using System;

[assembly: System.Runtime.CompilerServices.InternalsVisibleTo("VWorldLod.Tests")]

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
        internal GameObject owner;
        public Transform transform { get { return owner.transform; } }
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
        readonly System.Collections.Generic.List<Component> components = new System.Collections.Generic.List<Component>();

        public GameObject(string name)
        {
            this.name = name;
            AddComponent<Transform>();
        }

        public Transform transform { get { return GetComponent<Transform>(); } }

        public T GetComponent<T>()
        {
            foreach (Component c in components) if (c is T) return (T)(object)c;
            return default(T);
        }

        public T AddComponent<T>() where T : Component
        {
            T c = (T)Activator.CreateInstance(typeof(T), true);
            c.owner = this;
            components.Add(c);
            return c;
        }

        public T[] GetComponentsInChildren<T>() { throw new NotSupportedException("stand-in"); }
    }

    public struct Vector3
    {
        internal float[] values;
        public Vector3(float x, float y, float z) { values = new[] { x, y, z }; }
    }

    public struct Quaternion
    {
        internal float[] values;
        public Quaternion(float x, float y, float z, float w) { values = new[] { x, y, z, w }; }
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
        internal float height;
        internal Renderer[] given;

        public LOD(float screenRelativeTransitionHeight, Renderer[] renderers)
        {
            fadeTransitionWidth = 0f;
            height = screenRelativeTransitionHeight;
            given = renderers;
        }
    }

    public class LODGroup : Component
    {
        public LODFadeMode fadeMode { get; set; }
        public bool animateCrossFading { get; set; }
        internal LOD[] lods;
        internal int boundsRecalculated;
        public void SetLODs(LOD[] lods) { this.lods = (LOD[])lods.Clone(); }
        public void RecalculateBounds() { boundsRecalculated++; }
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
