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
        /// "expected": ["tile/id" per triangle], "vertices": ["tile/id" per vertex],
        /// "attributes": {"tile/id": {name: value from the glb's property table}}}]} written by tests/test_unity_package.py.
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
                var attributes = (Dictionary<string, object>)proxy["attributes"];
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
                        BuildingAttribute[] values;
                        Assert.True(BuildingPicking.Resolve(new RaycastHit { hitCollider = collider, faceId = k }, out tile, out id, out values), "resolved " + k);
                        ProxyFeatures.Split((string)expected[k], out wantTile, out wantId);
                        Assert.Equal(wantTile, tile, "tile of triangle " + k);
                        Assert.Equal(wantId, id, "id of triangle " + k);
                        CheckValues((Dictionary<string, object>)attributes[(string)expected[k]], values);
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

        /// <summary>A building level hit: its BuildingAttributes (and its tile root's name) answer.</summary>
        public static void RunSelfContained(TestRunner t)
        {
            foreach (var bad in new[]
            {
                new[] { "{\"buildings\": [\"t/a\"], \"owners\": [[1, 3]]}", "r.json: owners[0]: building index 1 is not in buildings (1 of them)" },
                new[] { "{\"buildings\": [\"t/a\"], \"owners\": [[0, -3]]}", "r.json: owners[0]: not a [building index, vertex count] pair" },
                new[] { "{\"buildings\": [\"t/a\"]}", "r.json: owners: missing" },
                new[] { "{\"owners\": []}", "r.json: buildings: missing" },
                new[] { "{\"buildings\": [\"t/a\"], \"owners\": [[0, 3]], \"values\": []}", "r.json: values: 0 entries for 1 buildings" },
                new[] { "[1,", "r.json: not JSON" },
            })
            {
                t.Check("picking: a broken proxy record is refused: " + bad[1], () =>
                {
                    try
                    {
                        ProxyFeatures.Parse(bad[0], "r.json", 3);
                    }
                    catch (ManifestException e)
                    {
                        Assert.True(e.Message.StartsWith(bad[1]), e.Message);
                        return;
                    }
                    throw new TestFailure("accepted");
                });
            }
            t.Check("picking: runs of zero vertices are skipped", () =>
            {
                ProxyFeatures f = ProxyFeatures.Parse("{\"buildings\": [\"t/a\", \"t/b\", \"t/c\"], \"owners\": [[0, 2], [1, 0], [2, 1], [0, 0]]}", "r.json", 3);
                Assert.Equal("t/a", f.BuildingAt(1), "vertex 1");
                Assert.Equal("t/c", f.BuildingAt(2), "vertex 2");
                Assert.Equal("t/c", f.BuildingOfTriangle(new[] { 2, 0, 1 }, 0), "triangle 0");
                Assert.Equal(0, f.Values[2].Length, "no values");
            });
            t.Check("picking: a hit on a building level resolves to its BuildingAttributes and tile", () =>
            {
                var tileRoot = new GameObject("tile");
                tileRoot.AddComponent<VWorldLodTilePlacement>().tileName = "15_1_2";
                var building = new GameObject("B1");
                building.transform.SetParent(tileRoot.transform, false);
                BuildingAttributes component = building.AddComponent<BuildingAttributes>();
                component.buildingId = "B1";
                component.attributes.Add(new BuildingAttribute("year", "1990", "number"));
                var level = new GameObject("LOD0");
                level.transform.SetParent(building.transform, false);
                string tile, id;
                BuildingAttribute[] values;
                Assert.True(BuildingPicking.Resolve(new RaycastHit { hitCollider = level.AddComponent<MeshCollider>(), faceId = 3 }, out tile, out id, out values), "resolved");
                Assert.Equal("15_1_2", tile, "tile");
                Assert.Equal("B1", id, "id");
                Assert.Equal("1990", values[0].value, "attribute");
                Assert.True(!BuildingPicking.Resolve(new RaycastHit { hitCollider = new GameObject("ground").AddComponent<MeshCollider>(), faceId = 0 }, out tile, out id), "an unrelated collider resolves to nothing");
            });
        }

        static void CheckValues(Dictionary<string, object> expected, BuildingAttribute[] values)
        {
            Assert.Equal(expected.Count, values.Length, "values");
            foreach (BuildingAttribute value in values)
            {
                object want = expected[value.name];
                if (want is double) Assert.Equal((double)want, double.Parse(value.value, System.Globalization.CultureInfo.InvariantCulture), value.name);
                else if (want is bool) Assert.Equal((bool)want ? "true" : "false", value.value, value.name);
                else Assert.Equal((string)want, value.value, value.name);
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
