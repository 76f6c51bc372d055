// Building attributes in Unity (Runtime/Plan/AttributeReader.cs, Runtime/Unity/BuildingAttributes.cs)
// on a manifest written by the Python exporter: every building's component, as the Editor import
// (LodGroupAssembly.Configure) and the streamer (ConfigureLoaded, some levels) attach it, holds the
// manifest's id, source and attributes with the same values.
using System;
using System.Collections.Generic;
using System.Globalization;
using UnityEngine;

namespace VWorldLod.Tests
{
    public static class AttributeTests
    {
        public static void Run(TestRunner t, string manifestPath)
        {
            var expected = (Dictionary<string, object>)PlainJson.Parse(System.IO.File.ReadAllText(manifestPath));
            TilePlan plan = LodPlanner.Load(manifestPath, new PlainJsonManifestParser(), p => true);
            var records = new Dictionary<string, Dictionary<string, object>>();
            foreach (object b in (List<object>)expected["buildings"])
            {
                var record = (Dictionary<string, object>)b;
                records[(string)record["id"]] = record;
            }
            foreach (BuildingPlan building in plan.Buildings)
            {
                foreach (bool streamed in new[] { false, true })
                {
                    t.Check("attributes: " + building.Id + (streamed ? " (streamed)" : " (prefab)"), () =>
                    {
                        var root = new GameObject(building.Name);
                        int count = streamed ? 1 : building.Levels.Length;
                        var objects = new GameObject[count];
                        var renderers = new Renderer[count][];
                        var levels = new int[count];
                        for (int k = 0; k < count; k++)
                        {
                            objects[k] = new GameObject("LOD" + k);
                            renderers[k] = new[] { new Renderer() };
                            levels[k] = streamed ? building.Levels.Length - 1 : k;
                        }
                        if (streamed) LodGroupAssembly.ConfigureLoaded(root, building, plan, levels, objects, renderers);
                        else LodGroupAssembly.Configure(root, building, plan, objects, renderers);
                        Check(root.GetComponent<BuildingAttributes>(), records[building.Id]);
                    });
                }
            }
        }

        static void Check(BuildingAttributes component, Dictionary<string, object> record)
        {
            Assert.True(component != null, "component attached");
            Assert.Equal((string)record["id"], component.buildingId, "id");
            Assert.Equal((string)record["source"], component.source, "source");
            object found;
            var attributes = record.TryGetValue("attributes", out found) ? (Dictionary<string, object>)found : new Dictionary<string, object>();
            Assert.Equal(attributes.Count, component.attributes.Count, "attribute count");
            Assert.True(attributes.Count > 0, "the building has attributes");
            foreach (var pair in attributes)
            {
                string value;
                Assert.True(component.TryGet(pair.Key, out value), "has " + pair.Key);
                Assert.Equal(value, component.Get(pair.Key), "Get " + pair.Key);
                if (pair.Value is double)
                    Assert.Equal((double)pair.Value, double.Parse(value, CultureInfo.InvariantCulture), pair.Key);
                else if (pair.Value is bool)
                    Assert.Equal((bool)pair.Value ? "true" : "false", value, pair.Key);
                else
                    Assert.Equal((string)pair.Value, value, pair.Key);
            }
            Assert.True(component.Get("no such attribute") == null, "a missing attribute is null");
        }
    }
}
