// Picking a building on a tile proxy (Runtime/Plan/ProxyFeatures.cs, Runtime/Unity/ProxyBuildings.cs,
// BuildingPicking.cs) on proxies made by the Python exporter: for every triangle of every proxy, the
// building the C# finds from the record (as a raycast would: the Unity mesh's triangles, indices
// flipped as glTFast flips them) is the one the Python side found from the glb's _FEATURE_ID_0
// and its property table order; a record whose runs do not cover the mesh is refused.
using System;
using System.Collections.Generic;
using System.IO;
using UnityEngine;

namespace VWorldLod.Tests
{
    public static class PickingTests
    {
        /// <summary>
        /// casesPath: {"proxies": [{"record": path, "vertex_count": n, "indices": [glTF indices],
        /// "expected": ["tile/id" per triangle], "vertices": ["tile/id" per vertex]}]} written by tests/test_unity_package.py.
        /// </summary>
        public static void Run(TestRunner t, string casesPath)
        {
            var cases = (Dictionary<string, object>)PlainJson.Parse(File.ReadAllText(casesPath));
            foreach (object item in (List<object>)cases["proxies"])
            {
                var proxy = (Dictionary<string, object>)item;
                string record = (string)proxy["record"];
                string text = File.ReadAllText(record);
                int vertices = (int)(double)proxy["vertex_count"];
                int[] triangles = UnityTriangles((List<object>)proxy["indices"]);
                var expected = (List<object>)proxy["expected"];
                var perVertex = (List<object>)proxy["vertices"];
                string name = Path.GetFileName(record);
                t.Check("picking: every vertex and triangle of " + name + " resolves to its feature id's building", () =>
                {
                    ProxyFeatures features = ProxyFeatures.Parse(text, record, vertices);
                    Assert.Equal(expected.Count, triangles.Length / 3, "triangles");
                    for (int k = 0; k < expected.Count; k++)
                        Assert.Equal((string)expected[k], features.BuildingOfTriangle(triangles, k), "triangle " + k);
                    Assert.Equal(perVertex.Count, features.VertexCount, "vertices");
                    for (int v = 0; v < perVertex.Count; v++)
                        Assert.Equal((string)perVertex[v], features.BuildingAt(v), "vertex " + v);
                });
                t.Check("picking: a raycast hit on " + name + " resolves through BuildingPicking", () =>
                {
                    var root = new GameObject("proxy");
                    ProxyBuildings.Attach(root, name, ProxyFeatures.Parse(text, record, vertices));
                    var child = new GameObject("mesh");
                    child.transform.SetParent(root.transform, false);
                    MeshCollider collider = child.AddComponent<MeshCollider>();
                    collider.sharedMesh = new Mesh { triangles = triangles, verticesCount = vertices };
                    for (int k = 0; k < expected.Count; k += Math.Max(1, expected.Count / 50))
                    {
                        string tile, id, wantTile, wantId;
                        Assert.True(BuildingPicking.Resolve(new RaycastHit { hitCollider = collider, faceId = k }, out tile, out id), "resolved " + k);
                        ProxyFeatures.Split((string)expected[k], out wantTile, out wantId);
                        Assert.Equal(wantTile, tile, "tile of triangle " + k);
                        Assert.Equal(wantId, id, "id of triangle " + k);
                    }
                    string noTile, noId;
                    Assert.True(!BuildingPicking.Resolve(new RaycastHit { hitCollider = collider, faceId = triangles.Length / 3 }, out noTile, out noId), "a triangle past the mesh resolves to nothing");
                });
                foreach (int wrong in new[] { vertices - 1, vertices + 1 })
                {
                    t.Check("picking: " + name + "'s runs refused for a mesh of " + wrong + " vertices", () =>
                    {
                        try
                        {
                            ProxyFeatures.Parse(text, record, wrong);
                        }
                        catch (ManifestException e)
                        {
                            Assert.True(e.Message.StartsWith(record + ": owners: the runs cover " + vertices + " vertices, the proxy mesh has " + wrong), e.Message);
                            return;
                        }
                        throw new TestFailure("accepted");
                    });
                }
            }
        }

        // The glTF triangle list as glTFast gives it to Unity: each triangle (a, b, c) becomes
        // (a, c, b) (Jobs.cs ConvertIndices*FlippedJob / GltfToUnityTriangleIndies).
        static int[] UnityTriangles(List<object> indices)
        {
            var result = new int[indices.Count];
            for (int i = 0; i + 2 < indices.Count; i += 3)
            {
                result[i] = (int)(double)indices[i];
                result[i + 1] = (int)(double)indices[i + 2];
                result[i + 2] = (int)(double)indices[i + 1];
            }
            return result;
        }
    }
}
