// The buildings merged in a streamed tile proxy, on the proxy's root: their keys
// ("<tile>/<building id>", shown in the Inspector) and which building each vertex of its mesh came
// from (ProxyFeatures, read from the proxy's record beside its .glb when it loads). A raycast on
// the proxy (a MeshCollider: VWorldLodStreamer.proxyColliders, or one's own) resolves with
// BuildingPicking.Resolve or Resolve(triangles, triangleIndex) here.
using System.Collections.Generic;
using UnityEngine;

namespace VWorldLod
{
    public class ProxyBuildings : MonoBehaviour
    {
        /// <summary>The proxy's name (its tile, e.g. "14_139709_58056").</summary>
        public string proxy;
        /// <summary>The buildings merged in it, "&lt;tile&gt;/&lt;building id&gt;", in the record's order.</summary>
        public List<string> buildings = new List<string>();

        ProxyFeatures features;

        /// <summary>The per-vertex owners (null until attached).</summary>
        public ProxyFeatures Features { get { return features; } }

        /// <summary>
        /// The building of triangle triangleIndex of the proxy mesh's index list triangles
        /// (Mesh.triangles; RaycastHit.triangleIndex), split into its tile and building id, and its
        /// metadata values (id, source_id, source_file, height and its source attributes).
        /// False when the proxy has no features or the triangle is not in the mesh.
        /// </summary>
        public bool Resolve(int[] triangles, int triangleIndex, out string tile, out string buildingId, out BuildingAttribute[] values)
        {
            tile = buildingId = null;
            values = null;
            if (features == null || triangles == null || triangleIndex < 0 || 3 * (long)triangleIndex + 2 >= triangles.Length) return false;
            int vertex = triangles[3 * triangleIndex];
            if (vertex < 0 || vertex >= features.VertexCount) return false;
            int owner = features.OwnerAt(vertex);
            ProxyFeatures.Split(features.Buildings[owner], out tile, out buildingId);
            values = features.Values[owner];
            return true;
        }

        /// <summary>The component on root (added once, refilled on every call) holding features of the proxy named proxyName.</summary>
        public static ProxyBuildings Attach(GameObject root, string proxyName, ProxyFeatures features)
        {
            ProxyBuildings component = root.GetComponent<ProxyBuildings>();
            if (component == null) component = root.AddComponent<ProxyBuildings>();
            component.proxy = proxyName;
            component.features = features;
            component.buildings = new List<string>(features.Buildings);
            return component;
        }
    }
}
