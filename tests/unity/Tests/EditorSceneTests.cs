// What the package's Unity components decide, run on the stand-ins: glTFast's import settings
// for streamed levels, listeners told when the georeference goes away, which tile roots the
// Editor places (Prefab Mode, the Scene view's drag preview), and the cross-fade warning.
// MonoBehaviour messages (OnEnable, OnDisable) are invoked by reflection, as Unity does.
using System;
using System.Reflection;
using System.Threading;
using GLTFast;
using UnityEngine;

namespace VWorldLod.Tests
{
    public static class EditorSceneTests
    {
        static void Send(object component, string message)
        {
            MethodInfo method = component.GetType().GetMethod(message, BindingFlags.Instance | BindingFlags.NonPublic | BindingFlags.Public);
            method.Invoke(component, null);
        }

        // Place() sets the root's world pose (on the globe here: no georeference is active).
        static bool Placed(VWorldLodTilePlacement tile)
        {
            Vector3 p = tile.transform.position;
            return p.x != 0 || p.y != 0 || p.z != 0;
        }

        static VWorldLodTilePlacement Tile(string name, double lon)
        {
            var tile = new GameObject(name).AddComponent<VWorldLodTilePlacement>();
            tile.centerLongitude = lon;
            tile.centerLatitude = 37.5665;
            return tile;
        }

        public static void Run(TestRunner t)
        {
            t.Check("loader: glTFast builds mipmaps for streamed levels, as its Editor importer does", () =>
            {
                Assert.True(GltfLevelLoader.LevelImportSettings().GenerateMipMaps, "LevelImportSettings");
                GltfImportBase.loadedWith.Clear();
                int disposed = GltfImportBase.disposed;
                var parent = new GameObject("building");
                // The stand-in Load reports failure: the level is cleaned up and null returned.
                GltfImportBase.loadedBytes.Clear();
                var glb = new byte[] { 0x67, 0x6c, 0x54, 0x46 };
                LoadedLevel level = GltfLevelLoader.LoadBytesAsync(glb, "file:///tiles/B1/lod0.glb", parent.transform, "B1_LOD0", CancellationToken.None).Result;
                Assert.True(level == null, "failed load gives null");
                Assert.Equal(1, GltfImportBase.loadedWith.Count, "Load calls");
                Assert.True(GltfImportBase.loadedBytes[0] == glb, "glTFast is given the downloaded bytes (our download, which cancellation aborts)");
                ImportSettings settings = GltfImportBase.loadedWith[0];
                Assert.True(settings != null && settings.GenerateMipMaps, "Load was given GenerateMipMaps = true");
                Assert.Equal(disposed + 1, GltfImportBase.disposed, "the failed import disposed");
            });

            t.Check("georeference: disabling the current one re-places tiles and tells listeners", () =>
            {
                var first = new GameObject("first").AddComponent<VWorldLodGeoreference>();
                var second = new GameObject("second").AddComponent<VWorldLodGeoreference>();
                second.longitude = 127.0;
                int told = 0;
                Action listener = () => told++;
                Send(first, "OnEnable");
                Send(second, "OnEnable");
                VWorldLodGeoreference.OriginChanged += listener;
                try
                {
                    Send(second, "OnDisable"); // not the current one: nothing moves
                    Assert.Equal(0, told, "listeners told when a georeference that was not in use went away");
                    Send(second, "OnEnable");
                    told = 0;
                    Send(first, "OnDisable"); // second takes over
                    Assert.Equal(1, told, "listeners told when the current georeference went away");
                    Assert.True(ReferenceEquals(second, VWorldLodGeoreference.Current), "the other one took over");
                    Send(second, "OnDisable"); // none left: globe placement
                    Assert.Equal(2, told, "listeners told when the last georeference went away");
                    Assert.True(VWorldLodGeoreference.CurrentOrigin == null, "no origin left");
                }
                finally
                {
                    VWorldLodGeoreference.OriginChanged -= listener;
                }
            });

            t.Check("editor scope: tile roots are placed only in the edited scene", () =>
            {
                Assert.True(PlacementScope.Places(false, false, false), "a tile root of the edited scene");
                foreach (bool stage in new[] { false, true })
                    foreach (bool preview in new[] { false, true })
                        foreach (bool hidden in new[] { false, true })
                            if (stage || preview || hidden)
                                Assert.True(!PlacementScope.Places(stage, preview, hidden),
                                            "prefab stage " + stage + ", preview scene " + preview + ", hidden " + hidden);
            });

            t.Check("editor scope: a drag preview or Prefab Mode root is neither placed nor given a georeference", () =>
            {
                // [InitializeOnLoad]: Unity runs the hook's static constructor when the Editor loads.
                System.Runtime.CompilerServices.RuntimeHelpers.RunClassConstructor(typeof(EditorTools.TilePlacementHook).TypeHandle);
                Assert.True(VWorldLodTilePlacement.AutoPlaces == EditorTools.TilePlacementHook.InEditedScene, "the Editor feeds its rule to the placement");
                Func<GameObject, bool> saved = VWorldLodTilePlacement.AutoPlaces;
                try
                {
                    // As TilePlacementHook feeds the rule: here only hideFlags varies.
                    VWorldLodTilePlacement.AutoPlaces = go => PlacementScope.Places(go.name == "in prefab mode", false, (go.hideFlags & HideFlags.HideInHierarchy) != 0);
                    VWorldLodTilePlacement preview = Tile("dragged", 126.97), prefabRoot = Tile("in prefab mode", 126.98), placed = Tile("dropped", 126.99);
                    preview.gameObject.hideFlags = HideFlags.HideInHierarchy; // GameObjectInspector.OnSceneDragInternal
                    var all = new[] { preview, prefabRoot, placed };
                    foreach (VWorldLodTilePlacement tile in all) Send(tile, "OnEnable");
                    try
                    {
                        Assert.True(!Placed(preview) && !Placed(prefabRoot), "hidden and Prefab Mode roots left alone on enable");
                        Assert.True(Placed(placed), "the scene's tile placed on enable");
                        Assert.True(ReferenceEquals(placed, EditorTools.TilePlacementHook.GeoreferenceSite(all)), "georeference at the scene's tile");
                        Assert.True(EditorTools.TilePlacementHook.GeoreferenceSite(new[] { preview, prefabRoot }) == null, "no georeference for a drag preview or Prefab Mode");
                        placed.transform.position = new Vector3(0, 0, 0);
                        VWorldLodTilePlacement.PlaceAll(); // the origin moved
                        Assert.True(Placed(placed) && !Placed(preview) && !Placed(prefabRoot), "origin moves re-place the scene's tiles only");
                        preview.gameObject.hideFlags = HideFlags.None; // dropped: DragPerform unhides it
                        Assert.True(preview.PlacesAutomatically, "placed once dropped");
                    }
                    finally
                    {
                        foreach (VWorldLodTilePlacement tile in all) Send(tile, "OnDisable");
                    }
                }
                finally
                {
                    VWorldLodTilePlacement.AutoPlaces = saved;
                }
            });

            t.Check("fade: cross_fade is warned about (glTFast's shaders do not cross-fade), none is not", () =>
            {
                TilePlan plan = LodPlanner.Plan(PlanTests.Parse(PlanTests.Sample), PlanTests.ManifestPath, p => true);
                Assert.Equal(LodFadeKind.CrossFade, plan.FadeMode, "the sample asks for cross_fade");
                string warning = LodPlanner.FadeWarning(plan);
                Assert.Contains(PlanTests.ManifestPath, warning, "names the manifest");
                Assert.Contains("cross-fade", warning, "says why");
                Assert.Contains("fade_mode: none", warning, "says what to do");
                foreach (LodFadeKind kind in new[] { LodFadeKind.None, LodFadeKind.SpeedTree })
                {
                    plan.FadeMode = kind;
                    Assert.True(LodPlanner.FadeWarning(plan) == null, "no warning for " + kind);
                }
            });
        }
    }
}
