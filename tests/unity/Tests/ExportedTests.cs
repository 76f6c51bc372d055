// Tests on files handed in by tests/test_unity_package.py: a manifest written by the Python
// exporter, broken variants of it, and placements computed by exporter.placement.
using System;
using System.Collections.Generic;
using System.IO;

namespace VWorldLod.Tests
{
    public static class ExportedTests
    {
        /// <summary>Relative agreement asked of every placement comparison (stricter than the 1e-6 of the brief).</summary>
        public const double Relative = 1e-9;

        static readonly Dictionary<string, double> worst = new Dictionary<string, double>();

        static void Record(string what, double error)
        {
            double previous;
            if (!worst.TryGetValue(what, out previous) || error > previous) worst[what] = error;
        }

        public static void PrintMeasurements()
        {
            foreach (var pair in worst)
                Console.WriteLine("MEASURE " + pair.Key + " " + pair.Value.ToString("R"));
        }

        /// <summary>Position relative to its length (at least 1), rotation up to sign, scale relative.</summary>
        public static void SamePose(Placement expected, Placement actual, string what, string measure)
        {
            double norm = Math.Max(1, Math.Sqrt(expected.px * expected.px + expected.py * expected.py + expected.pz * expected.pz));
            double dp = Math.Sqrt(Sq(expected.px - actual.px) + Sq(expected.py - actual.py) + Sq(expected.pz - actual.pz)) / norm;
            double dq = Math.Min(
                Math.Sqrt(Sq(expected.qx - actual.qx) + Sq(expected.qy - actual.qy) + Sq(expected.qz - actual.qz) + Sq(expected.qw - actual.qw)),
                Math.Sqrt(Sq(expected.qx + actual.qx) + Sq(expected.qy + actual.qy) + Sq(expected.qz + actual.qz) + Sq(expected.qw + actual.qw)));
            double ds = Math.Abs(expected.scale - actual.scale) / Math.Abs(expected.scale);
            Record(measure + ".position_rel", dp);
            Record(measure + ".rotation_abs", dq);
            Record(measure + ".scale_rel", ds);
            if (dp > Relative || dq > Relative || ds > Relative)
                throw new TestFailure(what + ": expected " + expected + ", got " + actual
                                      + " (position error " + dp + " relative, rotation " + dq + ", scale " + ds + ")");
        }

        static double Sq(double x) { return x * x; }

        static Placement GlobePose(GeoCenter c, GlobeInfo g)
        {
            double[] p = Placement.GlobePosition(c.lon, c.lat, c.elev, g.earth_radius_m, g.unity_radius);
            double[] q = Placement.EastUpNorthRotation(c.lon, c.lat);
            return new Placement(p[0], p[1], p[2], q[0], q[1], q[2], q[3], g.unity_radius / g.earth_radius_m);
        }

        public static void RunManifest(TestRunner t, string path)
        {
            var parser = new PlainJsonManifestParser();
            TileManifest m = null;
            t.Check("exported: parses", () => m = parser.Parse(File.ReadAllText(path), path));
            if (m == null) return;
            t.Check("exported: every building planned, every level file present", () =>
            {
                TilePlan plan = LodPlanner.Load(path, parser, File.Exists);
                foreach (ManifestException f in plan.Failures) throw new TestFailure("unexpected failure: " + f.Message);
                Assert.True(m.buildings.Length > 0, "the manifest has buildings");
                Assert.Equal(m.buildings.Length, plan.Buildings.Length, "buildings planned");
                double[] heights = m.lod_group.screen_relative_heights;
                for (int i = 0; i < plan.Buildings.Length; i++)
                {
                    BuildingPlan b = plan.Buildings[i];
                    Assert.Equal(m.buildings[i].id, b.Id, "order kept");
                    Assert.Equal(m.buildings[i].lods.Length, b.Levels.Length, b.Id + " levels");
                    for (int k = 0; k < b.Levels.Length; k++)
                    {
                        Assert.True(File.Exists(b.Levels[k].Path), b.Levels[k].Path + " exists");
                        Assert.Equal(LodPlanner.LevelHeight(heights, k, b.Levels.Length), b.Levels[k].ScreenRelativeHeight, b.Id + " height " + k);
                    }
                    for (int k = 1; k < b.Levels.Length; k++)
                        Assert.True(b.Levels[k].ScreenRelativeHeight < b.Levels[k - 1].ScreenRelativeHeight, b.Id + " heights decrease");
                }
            });
            t.Check("exported: tile root is equations (1)-(2) and East/Up/North at the tile centre", () =>
                SamePose(GlobePose(m.tile.center, m.globe), Placement.FromData(m.tile.placement), "tile.placement", "tile_root_vs_csharp_globe"));
            t.Check("exported: building placements are equations (1)-(2) at their centres", () =>
            {
                foreach (BuildingEntry b in m.buildings)
                    SamePose(GlobePose(b.center, m.globe), Placement.FromData(b.placement), b.id + " placement", "building_vs_csharp_globe");
            });
            t.Check("exported: tile root composed with relative_placement is the globe placement", () =>
            {
                Placement root = Placement.FromData(m.tile.placement);
                foreach (BuildingEntry b in m.buildings)
                    SamePose(Placement.FromData(b.placement), Placement.Compose(root, Placement.FromData(b.relative_placement)), b.id, "csharp_compose_vs_manifest_globe");
            });
            t.Check("exported: a tile root's placement component puts it at tile.placement (globe) or RootPose (georeferenced)", () =>
            {
                TilePlan plan = LodPlanner.Plan(m, path, p => true);
                var placement = new UnityEngine.GameObject("tile").AddComponent<VWorldLodTilePlacement>();
                placement.Configure(plan);
                SamePose(Placement.FromData(m.tile.placement), placement.Pose(null), "globe pose", "tile_component_globe");
                var origin = new GeoOrigin(m.tile.center.lon + 0.01, m.tile.center.lat - 0.01, 12);
                SamePose(plan.RootPose(origin), placement.Pose(origin), "georeferenced pose", "tile_component_georef");
                placement.Place(); // no georeference in this "scene": the globe pose, as floats
                UnityEngine.Vector3 at = placement.transform.position;
                Assert.Near(m.tile.placement.position[0], at.x, 1, "x (float32 of ~6e6)");
                Assert.True(!placement.transform.hasChanged, "placing clears hasChanged");
            });
            t.Check("exported: both placement modes put each building at the same globe pose", () =>
            {
                string keep = m.globe.placement;
                try
                {
                    m.globe.placement = "tile_relative";
                    TilePlan relative = LodPlanner.Plan(m, path, File.Exists);
                    m.globe.placement = "globe";
                    TilePlan globe = LodPlanner.Plan(m, path, File.Exists);
                    for (int i = 0; i < relative.Buildings.Length; i++)
                        SamePose(Placement.Compose(globe.TileRoot, globe.Buildings[i].Local),
                                 Placement.Compose(relative.TileRoot, relative.Buildings[i].Local), relative.Buildings[i].Id, "modes_agree");
                }
                finally
                {
                    m.globe.placement = keep;
                }
            });
        }

        /// <summary>The manifest at path must be refused, naming path and a field starting with field.</summary>
        public static void RunBroken(TestRunner t, string path, string field)
        {
            t.Check("broken: " + Path.GetFileName(path) + " -> " + field, () =>
            {
                ManifestException error = null;
                try
                {
                    TilePlan plan = LodPlanner.Load(path, new PlainJsonManifestParser(), File.Exists);
                    if (plan.Failures.Length > 0) error = plan.Failures[0];
                }
                catch (ManifestException e)
                {
                    error = e;
                }
                if (error == null) throw new TestFailure("accepted without any error");
                Console.WriteLine("ERROR " + error.Message);
                Assert.True(error.Field.StartsWith(field), "field \"" + error.Field + "\" starts with \"" + field + "\"");
                Assert.True(error.Message.StartsWith(path + ": "), "message starts with the manifest path: " + error.Message);
            });
        }

        /// <summary>
        /// Cases from exporter.placement: {"cases": [{"name", "tile", "relative", "composed", "building"}]},
        /// each a placement dict; C#'s Compose(tile, relative) must match Python's compose and
        /// building_placement.
        /// </summary>
        public static void RunPlacements(TestRunner t, string path)
        {
            var root = (Dictionary<string, object>)PlainJson.Parse(File.ReadAllText(path));
            var cases = (List<object>)root["cases"];
            t.Check("placements: file has cases", () => Assert.True(cases.Count > 0, "cases"));
            foreach (object item in cases)
            {
                var c = (Dictionary<string, object>)item;
                string name = (string)c["name"];
                t.Check("placements: " + name, () =>
                {
                    Placement composed = Placement.Compose(ToPose(c["tile"]), ToPose(c["relative"]));
                    SamePose(ToPose(c["composed"]), composed, name + " vs Python compose", "csharp_vs_python_compose");
                    SamePose(ToPose(c["building"]), composed, name + " vs Python building_placement", "csharp_compose_vs_python_building");
                });
            }
        }

        /// <summary>{"names": [{"id", "safe"}]} from exporter.names.safe_folder_name.</summary>
        public static void RunNames(TestRunner t, string path)
        {
            var root = (Dictionary<string, object>)PlainJson.Parse(File.ReadAllText(path));
            var names = (List<object>)root["names"];
            t.Check("names: same safe names as the exporter (" + names.Count + " ids)", () =>
            {
                Assert.True(names.Count > 0, "names");
                foreach (object item in names)
                {
                    var n = (Dictionary<string, object>)item;
                    Assert.Equal((string)n["safe"], LodPlanner.SafeName((string)n["id"]), "safe name of " + n["id"]);
                }
            });
        }

        public static Placement ToPose(object value)
        {
            var d = (Dictionary<string, object>)value;
            var p = (List<object>)d["position"];
            var q = (List<object>)d["rotation"];
            return new Placement((double)p[0], (double)p[1], (double)p[2], (double)q[0], (double)q[1], (double)q[2], (double)q[3], (double)d["scale"]);
        }
    }
}
