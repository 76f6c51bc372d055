// The thin Unity layer (Runtime/Unity/LodGroupAssembly.cs) run against the stand-in
// UnityEngine, whose GameObject, Transform and LODGroup record what they are given.
using System;
using System.Linq;
using UnityEngine;

namespace VWorldLod.Tests
{
    public static class UnityLayerTests
    {
        static GameObject[] LevelObjects(int count)
        {
            var objects = new GameObject[count];
            for (int k = 0; k < count; k++) objects[k] = new GameObject("LOD" + k);
            return objects;
        }

        public static void Run(TestRunner t)
        {
            t.Check("unity: LODGroup gets one LOD per level with the plan's heights, fade and renderers", () =>
            {
                TilePlan plan = LodPlanner.Plan(PlanTests.Parse(PlanTests.Sample), PlanTests.ManifestPath, p => true);
                BuildingPlan b = plan.Buildings[0];
                var root = new GameObject(b.Name);
                var renderers = new Renderer[b.Levels.Length][];
                for (int k = 0; k < renderers.Length; k++) renderers[k] = new[] { new Renderer(), new Renderer() };
                LODGroup group = LodGroupAssembly.Configure(root, b, plan, LevelObjects(renderers.Length), renderers);
                Assert.True(ReferenceEquals(group, root.GetComponent<LODGroup>()), "group added to the root");
                Assert.Equal(3, group.lods.Length, "levels");
                float[] expected = { 0.5f, 0.17f, 0.02f };
                for (int k = 0; k < 3; k++)
                {
                    Assert.Equal(expected[k], group.lods[k].height, "height " + k);
                    Assert.Equal(0.25f, group.lods[k].fadeTransitionWidth, "fade width " + k);
                    Assert.True(ReferenceEquals(renderers[k], group.lods[k].given), "renderers of level " + k);
                }
                Assert.Equal(LODFadeMode.CrossFade, group.fadeMode, "fade mode");
                Assert.True(group.animateCrossFading, "animate cross-fading");
                Assert.Equal(1, group.boundsRecalculated, "bounds recalculated after SetLODs");
            });
            t.Check("unity: re-configuring reuses the LODGroup", () =>
            {
                TilePlan plan = LodPlanner.Plan(PlanTests.Parse(PlanTests.Sample), PlanTests.ManifestPath, p => true);
                BuildingPlan b = plan.Buildings[1];
                var root = new GameObject(b.Name);
                var renderers = new[] { new Renderer[0], new Renderer[0] };
                LODGroup first = LodGroupAssembly.Configure(root, b, plan, LevelObjects(2), renderers);
                LODGroup second = LodGroupAssembly.Configure(root, b, plan, LevelObjects(2), renderers);
                Assert.True(ReferenceEquals(first, second), "same component");
                Assert.Equal(2, second.lods.Length, "levels");
                Assert.Equal(0.02f, second.lods[1].height, "last level down to the culling height");
            });
            t.Check("unity: level objects are active before the LODs and bounds are set from their renderers", () =>
            {
                TilePlan plan = LodPlanner.Plan(PlanTests.Parse(PlanTests.Sample), PlanTests.ManifestPath, p => true);
                BuildingPlan b = plan.Buildings[0];
                var levels = new[] { 1, 2 }; // streamed coarsest first: LOD0 still loading
                GameObject[] objects = LevelObjects(levels.Length);
                var renderers = new Renderer[levels.Length][];
                for (int i = 0; i < levels.Length; i++)
                {
                    objects[i].SetActive(false); // as GltfLevelLoader leaves a loaded level
                    renderers[i] = new[] { objects[i].AddComponent<Renderer>() };
                }
                LODGroup group = LodGroupAssembly.ConfigureLoaded(new GameObject(b.Name), b, plan, levels, objects, renderers);
                Assert.True(objects.All(o => o.active), "level objects activated");
                Assert.Equal(0, group.inactiveAtSetLODs, "renderers inactive when the LODs were set");
                Assert.Equal(1, group.boundsRecalculated, "bounds recalculated");
                Assert.Equal(0, group.inactiveAtBounds, "renderers inactive when the bounds were recalculated");
            });
            t.Check("unity: pose goes to the local transform as floats (x, y, z, w order)", () =>
            {
                var go = new GameObject("x");
                LodGroupAssembly.ApplyPlacement(go.transform, new Placement(1.5, -2, 3.25, 0, 0.6, 0, 0.8, 2));
                float[] p = go.transform.localPosition.values, q = go.transform.localRotation.values, s = go.transform.localScale.values;
                Assert.Equal("1.5 -2 3.25", string.Join(" ", p), "position");
                Assert.Equal("0 0.6 0 0.8", string.Join(" ", q), "rotation");
                Assert.Equal("2 2 2", string.Join(" ", s), "uniform scale");
            });
            t.Check("unity: a building streamed coarsest first shows its loaded levels with covering heights", () =>
            {
                TilePlan plan = LodPlanner.Plan(PlanTests.Parse(PlanTests.Sample), PlanTests.ManifestPath, p => true);
                BuildingPlan b = plan.Buildings[0]; // three levels: 0.5, 0.17, 0.02
                var cases = new[]
                {
                    new { Levels = new[] { 2 }, Heights = new[] { 0.02f } },
                    new { Levels = new[] { 1, 2 }, Heights = new[] { 0.17f, 0.02f } },
                    new { Levels = new[] { 0, 2 }, Heights = new[] { 0.17f, 0.02f } }, // level 1 failed: 0 covers it
                    new { Levels = new[] { 0, 1, 2 }, Heights = new[] { 0.5f, 0.17f, 0.02f } },
                    new { Levels = new[] { 0 }, Heights = new[] { 0.02f } },
                };
                foreach (var c in cases)
                {
                    var root = new GameObject(b.Name);
                    var renderers = new Renderer[c.Levels.Length][];
                    for (int i = 0; i < renderers.Length; i++) renderers[i] = new[] { new Renderer() };
                    LODGroup group = LodGroupAssembly.ConfigureLoaded(root, b, plan, c.Levels, LevelObjects(renderers.Length), renderers);
                    string what = "levels " + string.Join(",", c.Levels);
                    Assert.Equal(string.Join(" ", c.Heights), string.Join(" ", group.lods.Select(l => l.height)), what);
                    for (int i = 0; i < renderers.Length; i++)
                        Assert.True(ReferenceEquals(renderers[i], group.lods[i].given), what + ": renderers of entry " + i);
                }
            });
            t.Check("editor: no prefabs are built under StreamingAssets (refused before any asset is touched)", () =>
            {
                Assert.True(EditorTools.VWorldLodMenu.InStreamingAssets("Assets/StreamingAssets/city/15_1_1/lod_manifest.json"), "under StreamingAssets");
                Assert.True(EditorTools.VWorldLodMenu.InStreamingAssets("Assets\\StreamingAssets\\a.json"), "Windows separators");
                Assert.True(!EditorTools.VWorldLodMenu.InStreamingAssets("Assets/Tiles/15_1_1/lod_manifest.json"), "elsewhere under Assets");
                Assert.True(!EditorTools.VWorldLodMenu.InStreamingAssets("Assets/StreamingAssetsOld/lod_manifest.json"), "a look-alike folder");
                // The stand-in AssetDatabase and EditorUtility throw when called: Build must stop first.
                EditorTools.BuildReport report = EditorTools.LodGroupPrefabBuilder.Build("Assets/StreamingAssets/city/15_1_1/lod_manifest.json");
                Assert.Equal(1, report.Failed, "refused");
                Assert.Equal(0, report.Built, "nothing built");
            });
            t.Check("unity: LodFadeKind casts to the LODFadeMode of the same name", () =>
            {
                foreach (LodFadeKind kind in Enum.GetValues(typeof(LodFadeKind)))
                    Assert.Equal(kind.ToString(), ((LODFadeMode)(int)kind).ToString(), "cast of " + kind);
            });
        }
    }
}
