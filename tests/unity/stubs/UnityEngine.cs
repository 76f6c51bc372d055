// Stand-in for UnityEngine: declares exactly the members unity_package uses, with Unity's
// namespaces, type names and signatures (Unity 2022.3 and 6000.0 scripting API), so the
// package's scripts compile under mono. Bodies are minimal: GameObject keeps its components and
// its active state, LODGroup, the Transform's properties, SetParent and Destroy record what they
// are given (in non-public fields, which the C# tests read), and engine calls that need a running
// player throw.
using System;

[assembly: System.Runtime.CompilerServices.InternalsVisibleTo("VWorldLod.Tests")]

namespace UnityEngine
{
    public class Object
    {
        public string name { get; set; }
        public HideFlags hideFlags { get; set; }
        internal bool destroyed;
        public static void Destroy(Object obj) { obj.destroyed = true; }
        public static void DestroyImmediate(Object obj) { throw new NotSupportedException("stand-in"); }
    }

    [Flags]
    public enum HideFlags
    {
        None = 0,
        HideInHierarchy = 1,
    }

    public class Component : Object
    {
        internal GameObject owner;
        public Transform transform { get { return owner.transform; } }
        public GameObject gameObject { get { return owner; } }
        // Real: public T GetComponentInParent<T>() (this GameObject, then its parents).
        public T GetComponentInParent<T>()
        {
            for (Transform t = transform; t != null; t = t.parent)
            {
                T found = t.gameObject.GetComponent<T>();
                if (found != null) return found;
            }
            return default(T);
        }
    }

    public class Behaviour : Component { }

    public class MonoBehaviour : Behaviour { }

    public class Transform : Component
    {
        public Vector3 localPosition { get; set; }
        public Quaternion localRotation { get; set; }
        public Vector3 localScale { get; set; }
        // World pose of a root Transform (the stand-in has no hierarchy).
        public Vector3 position { get; set; }
        internal Quaternion worldRotation;
        public bool hasChanged { get; set; }
        public void SetPositionAndRotation(Vector3 position, Quaternion rotation)
        {
            this.position = position;
            worldRotation = rotation;
            hasChanged = true;
        }
        internal Transform parent;
        public void SetParent(Transform parent, bool worldPositionStays) { this.parent = parent; }
    }

    public class Camera : Behaviour
    {
        public static Camera main { get { throw new NotSupportedException("stand-in"); } }
        public float fieldOfView { get; set; }
        public int pixelHeight { get { throw new NotSupportedException("stand-in"); } }
    }

    [AttributeUsage(AttributeTargets.Class)]
    public sealed class ExecuteAlways : Attribute { }

    [AttributeUsage(AttributeTargets.Class)]
    public sealed class DisallowMultipleComponent : Attribute { }

    public class AsyncOperation
    {
        public event Action<AsyncOperation> completed { add { throw new NotSupportedException("stand-in"); } remove { } }
    }

    public enum LogType
    {
        Warning = 2,
        Log = 3,
    }

    // Real: public sealed partial class QualitySettings : Object, lodBias a static extern float property.
    public sealed class QualitySettings : Object
    {
        public static float lodBias { get; set; }
    }

    public class Renderer : Component
    {
        public Material[] sharedMaterials { get; set; }
    }

    // Textures and materials (Runtime/Export/Graphics, Runtime/Export/Shaders/Material*.cs).
    // Real: width and height are virtual properties of Texture (Texture2D overrides them).
    // Real: mipmapCount, wrapMode, filterMode, anisoLevel are Texture properties; graphicsFormat
    // a virtual one (2019.1+).
    public class Texture : Object
    {
        public virtual int width { get { throw new NotSupportedException("stand-in"); } set { } }
        public virtual int height { get { throw new NotSupportedException("stand-in"); } set { } }
        public int mipmapCount { get { throw new NotSupportedException("stand-in"); } }
        public TextureWrapMode wrapMode { get; set; }
        public FilterMode filterMode { get; set; }
        public int anisoLevel { get; set; }
        public virtual UnityEngine.Experimental.Rendering.GraphicsFormat graphicsFormat { get { throw new NotSupportedException("stand-in"); } }
    }

    // Real: Texture2D(int width, int height, GraphicsFormat format, int mipCount, TextureCreationFlags flags) (2019.3+).
    public sealed class Texture2D : Texture
    {
        public Texture2D(int width, int height, UnityEngine.Experimental.Rendering.GraphicsFormat format, int mipCount, UnityEngine.Experimental.Rendering.TextureCreationFlags flags)
        {
            throw new NotSupportedException("stand-in");
        }
    }

    // Real: public partial class Graphics; CopyTexture(Texture src, int srcElement, int srcMip, Texture dst, int dstElement, int dstMip).
    public class Graphics
    {
        public static void CopyTexture(Texture src, int srcElement, int srcMip, Texture dst, int dstElement, int dstMip) { throw new NotSupportedException("stand-in"); }
    }

    // Real: public sealed partial class SystemInfo; copyTextureSupport a static property.
    public sealed class SystemInfo
    {
        public static CopyTextureSupport copyTextureSupport { get { throw new NotSupportedException("stand-in"); } }
    }

    [Flags]
    public enum CopyTextureSupport
    {
        None = 0,
    }

    // Real: Material : Object; GetTexturePropertyNames() (2018.3+), GetTexture(string).
    public class Material : Object
    {
        public Material(Material source) { throw new NotSupportedException("stand-in"); }
        public string[] GetTexturePropertyNames() { throw new NotSupportedException("stand-in"); }
        public Texture GetTexture(string name) { throw new NotSupportedException("stand-in"); }
        public void SetTexture(string name, Texture value) { throw new NotSupportedException("stand-in"); }
    }

    public enum FilterMode
    {
        Trilinear = 2,
    }

    public enum TextureWrapMode
    {
        Repeat = 0,
    }

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
        public T[] GetComponentsInChildren<T>(bool includeInactive) { throw new NotSupportedException("stand-in"); }
        internal bool active = true;
        public void SetActive(bool value) { active = value; }
    }

    public struct Vector3
    {
        public float x, y, z;
        internal float[] values { get { return new[] { x, y, z }; } }
        public Vector3(float x, float y, float z) { this.x = x; this.y = y; this.z = z; }
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
        // Renderers on inactive GameObjects when the LODs were set / the bounds recalculated.
        internal int inactiveAtSetLODs, inactiveAtBounds;
        public void SetLODs(LOD[] lods)
        {
            this.lods = (LOD[])lods.Clone();
            inactiveAtSetLODs = Inactive();
        }
        public void RecalculateBounds()
        {
            boundsRecalculated++;
            inactiveAtBounds = Inactive();
        }
        int Inactive()
        {
            int n = 0;
            foreach (LOD lod in lods)
                foreach (Renderer r in lod.given)
                    if (r.owner != null && !r.owner.active) n++;
            return n;
        }
    }

    // Meshes and physics (Runtime/Export/Graphics/Mesh.cs, Modules/Physics/*.bindings.cs).
    // Real: public sealed partial class Mesh : Object; triangles { get; set; } (all sub-meshes'
    // indices, base vertex applied); vertexCount { get; }.
    public sealed class Mesh : Object
    {
        public int[] triangles { get; set; }
        public int vertexCount { get { return verticesCount; } }
        internal int verticesCount;
    }

    // Real: public sealed partial class MeshFilter : Component; sharedMesh { get; set; }.
    public sealed class MeshFilter : Component
    {
        public Mesh sharedMesh { get; set; }
    }

    // Real: public partial class Collider : Component; public partial class MeshCollider : Collider
    // with extern public Mesh sharedMesh { get; set; } (Modules/Physics/ScriptBindings).
    public class Collider : Component { }

    public class MeshCollider : Collider
    {
        public Mesh sharedMesh { get; set; }
    }

    // Real: public partial struct RaycastHit; collider { get; } (from m_Collider), triangleIndex
    // { get; } ((int)m_FaceID: the hit triangle's index in the MeshCollider's mesh).
    public struct RaycastHit
    {
        internal Collider hitCollider;
        internal int faceId;
        public Collider collider { get { return hitCollider; } }
        public int triangleIndex { get { return faceId; } }
    }

    public static class Debug
    {
        public static void Log(object message) { Console.WriteLine(message); }
        public static void LogError(object message) { Console.Error.WriteLine(message); }
        public static void LogWarning(object message) { Console.Error.WriteLine(message); }
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

namespace UnityEngine.Experimental.Rendering
{
    // Real: the texture formats (R8G8B8A8_SRGB, RGBA_DXT5_SRGB, ...); the package only passes one on.
    public enum GraphicsFormat
    {
    }

    [System.Flags]
    public enum TextureCreationFlags
    {
        None = 0,
        MipChain = 1,
    }
}

namespace UnityEngine.Networking
{
    public class DownloadHandler
    {
        public string text { get { throw new NotSupportedException("stand-in"); } }
        public byte[] data { get { throw new NotSupportedException("stand-in"); } }
    }

    public class UnityWebRequestAsyncOperation : AsyncOperation { }

    public class UnityWebRequest : IDisposable
    {
        public enum Result
        {
            Success = 1,
        }

        public static UnityWebRequest Get(string uri) { throw new NotSupportedException("stand-in"); }
        public UnityWebRequestAsyncOperation SendWebRequest() { throw new NotSupportedException("stand-in"); }
        public void Abort() { throw new NotSupportedException("stand-in"); }
        public void Dispose() { throw new NotSupportedException("stand-in"); }
        public Result result { get { throw new NotSupportedException("stand-in"); } }
        public string error { get { throw new NotSupportedException("stand-in"); } }
        public DownloadHandler downloadHandler { get { throw new NotSupportedException("stand-in"); } }
    }
}
