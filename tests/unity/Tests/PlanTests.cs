// Tests of the package's plain logic on manifests written here (no exporter needed): the JSON
// reader, the JsonUtility-like parser, validation, LoD planning and the placement arithmetic.
using System;
using System.Collections.Generic;
using System.IO;
using System.Linq;

namespace VWorldLod.Tests
{
    public static class PlanTests
    {
        public const string ManifestPath = "tiles/15_279418_116113/lod_manifest.json";

        // Two buildings, tile_relative; numbers are arbitrary but well formed (unit quaternions).
        public const string Sample = @"{
 ""format"": ""vworld-lod-manifest"", ""version"": ""1.0"",
 ""generator"": {""name"": ""vworld-lod"", ""version"": ""0.1.0""},
 ""config"": {""lods"": [{""transition"": 0.5}], ""anything"": {""nested"": [1, 2]}},
 ""tile"": {""level"": 15, ""idx"": 279418, ""idy"": 116113, ""name"": ""15_279418_116113"",
          ""bounds"": {""west"": 126.97, ""south"": 37.56, ""east"": 126.98, ""north"": 37.57},
          ""center"": {""lon"": 126.975, ""lat"": 37.565, ""elev"": 0},
          ""placement"": {""position"": [1000.5, 2000.25, -3000.125], ""rotation"": [0, 0.6, 0, 0.8], ""scale"": 2}},
 ""globe"": {""earth_radius_m"": 6378137, ""unity_radius"": 6378137, ""handedness"": ""left"", ""up"": ""y"",
           ""placement"": ""tile_relative""},
 ""lod_group"": {""screen_relative_heights"": [0.5, 0.17, 0.02], ""fade_mode"": ""cross_fade"",
               ""animate_cross_fading"": true, ""fade_transition_width"": 0.25, ""terrain_levels"": [15, 14, 13]},
 ""buildings"": [
  {""id"": ""B1"", ""source"": ""a.xdo"", ""input_hash"": ""ab"",
   ""center"": {""lon"": 126.976, ""lat"": 37.566, ""elev"": 12.5},
   ""placement"": {""position"": [1, 2, 3], ""rotation"": [0, 0, 0, 1], ""scale"": 1},
   ""relative_placement"": {""position"": [10, 0.5, -20], ""rotation"": [0.6, 0, 0, 0.8], ""scale"": 1},
   ""lods"": [{""level"": 0, ""file"": ""B1/lod0.glb"", ""triangles"": 300, ""vertices"": 400, ""texture_size"": [256, 256],
              ""quality"": {""triangle_ratio"": 1.0, ""some_future_metric"": 3}},
             {""level"": 1, ""file"": ""B1/lod1.glb"", ""triangles"": 200, ""vertices"": 300, ""texture_size"": [128, 128]},
             {""level"": 2, ""file"": ""B1/lod2.glb"", ""triangles"": 100, ""vertices"": 200, ""texture_size"": [64, 64]}],
   ""problems"": [""texture X.jpg missing: exported untextured""]},
  {""id"": ""B/2"", ""source"": ""b.xdo"",
   ""center"": {""lon"": 126.977, ""lat"": 37.567, ""elev"": 0},
   ""placement"": {""position"": [4, 5, 6], ""rotation"": [0, 0, 0, 1], ""scale"": 1},
   ""relative_placement"": {""position"": [-5, 0, 7], ""rotation"": [0, 0, 0, 1], ""scale"": 1},
   ""lods"": [{""level"": 0, ""file"": ""B_2/lod0.glb"", ""triangles"": 30, ""vertices"": 40, ""texture_size"": [0, 0]},
             {""level"": 1, ""file"": ""B_2/lod1.glb"", ""triangles"": 20, ""vertices"": 30, ""texture_size"": [0, 0]}],
   ""problems"": []}
 ],
 ""skipped"": [{""source"": ""c.xdo"", ""reason"": ""no triangles"", ""id"": ""B3""}],
 ""summary"": {""buildings"": 2, ""skipped"": 1,
             ""levels"": [{""level"": 0, ""mean_triangles"": 165, ""ratio_to_lod0"": 1.0, ""quality_mean"": {""x"": 1}}]}
}";

        static readonly HashSet<string> SampleFiles = new HashSet<string>
        {
            "tiles/15_279418_116113/B1/lod0.glb", "tiles/15_279418_116113/B1/lod1.glb", "tiles/15_279418_116113/B1/lod2.glb",
            "tiles/15_279418_116113/B_2/lod0.glb", "tiles/15_279418_116113/B_2/lod1.glb",
        };

        static bool SampleExists(string path) { return SampleFiles.Contains(path); }

        public static TileManifest Parse(string json)
        {
            return new PlainJsonManifestParser().Parse(json, ManifestPath);
        }

        static TilePlan PlanSample(Action<TileManifest> change)
        {
            TileManifest m = Parse(Sample);
            change(m);
            return LodPlanner.Plan(m, ManifestPath, SampleExists);
        }

        static ManifestException TileError(Action<TileManifest> change)
        {
            return Assert.Throws<ManifestException>(() => PlanSample(change), "tile-level validation");
        }

        static ManifestException OnlyFailure(TilePlan plan)
        {
            Assert.Equal(1, plan.Failures.Length, "failures");
            return plan.Failures[0];
        }

        public static void Run(TestRunner t)
        {
            // ---- JSON reader
            t.Check("json: nested values, escapes and numbers", () =>
            {
                var tree = (Dictionary<string, object>)PlainJson.Parse("{\"a\": [1, -2.5e-3, true, null, \"x\\u00e9\\n\\\"\"], \"b\": {}}");
                var a = (List<object>)tree["a"];
                Assert.Equal(5, a.Count, "array length");
                Assert.Equal(1.0, (double)a[0], "a[0]");
                Assert.Equal(-0.0025, (double)a[1], "a[1]");
                Assert.Equal(true, (bool)a[2], "a[2]");
                Assert.True(a[3] == null, "a[3] is null");
                Assert.Equal("x\u00e9\n\"", (string)a[4], "a[4]");
                Assert.Equal(0, ((Dictionary<string, object>)tree["b"]).Count, "b");
            });
            t.Check("json: doubles round-trip exactly", () =>
            {
                Assert.Equal(0.1 + 0.2, (double)PlainJson.Parse("0.30000000000000004"), "0.1+0.2");
                Assert.Equal(-4863817.123456789, (double)PlainJson.Parse("-4863817.123456789"), "globe coordinate");
            });
            foreach (string bad in new[] { "{\"a\": 1,}", "[1 2]", "{\"a\": 01}", "{'a': 1}", "{\"a\": NaN}", "{\"a\": 1, \"a\": 2}", "[1]x", "\"\\q\"", "{\"a\": [1, 2}" })
            {
                string text = bad;
                t.Check("json: rejects " + text, () => Assert.Throws<JsonSyntaxException>(() => PlainJson.Parse(text), text));
            }
            t.Check("json: error gives line and column", () =>
            {
                var e = Assert.Throws<JsonSyntaxException>(() => PlainJson.Parse("{\n  \"a\": 1,\n  \"b\": tru\n}"), "bad literal");
                Assert.Equal(3, e.Line, "line");
                Assert.Equal(8, e.Column, "column");
            });

            // ---- parser (JsonUtility rules)
            t.Check("parser: fills every declared field, ignores undeclared keys", () =>
            {
                TileManifest m = Parse(Sample);
                Assert.Equal("vworld-lod-manifest", m.format, "format");
                Assert.Equal(279418L, m.tile.idx, "tile.idx");
                Assert.Equal(3, m.lod_group.screen_relative_heights.Length, "heights");
                Assert.Equal(0.17, m.lod_group.screen_relative_heights[1], "heights[1]");
                Assert.Equal("cross_fade", m.lod_group.fade_mode, "fade_mode");
                Assert.Equal(2, m.buildings.Length, "buildings");
                Assert.Equal("B1/lod2.glb", m.buildings[0].lods[2].file, "file");
                Assert.Equal(128, m.buildings[0].lods[1].texture_size[0], "texture_size");
                Assert.Equal(1.0, m.buildings[0].lods[0].quality.triangle_ratio, "quality");
                Assert.Equal(-20.0, m.buildings[0].relative_placement.position[2], "relative z");
                Assert.Equal("B3", m.skipped[0].id, "skipped id");
                Assert.Equal(165.0, m.summary.levels[0].mean_triangles, "summary");
            });
            t.Check("parser: missing arrays and objects come back empty, like JsonUtility", () =>
            {
                TileManifest m = Parse("{\"format\": \"vworld-lod-manifest\"}");
                Assert.True(m.buildings != null && m.buildings.Length == 0, "buildings empty");
                Assert.True(m.tile != null && m.tile.placement != null, "nested objects created");
                Assert.True(m.lod_group.screen_relative_heights.Length == 0, "heights empty");
            });
            t.Check("parser: wrong type names the field", () =>
            {
                var e = Assert.Throws<ManifestException>(() => Parse(Sample.Replace("\"triangles\": 200", "\"triangles\": \"many\"")), "string for int");
                Assert.Equal("buildings[0].lods[1].triangles", e.Field, "field");
                Assert.Contains(ManifestPath, e.Message, "message names the manifest");
            });
            t.Check("parser: fractional count is rejected", () =>
            {
                var e = Assert.Throws<ManifestException>(() => Parse(Sample.Replace("\"vertices\": 400", "\"vertices\": 400.5")), "fraction");
                Assert.Equal("buildings[0].lods[0].vertices", e.Field, "field");
            });
            t.Check("parser: bad JSON names the manifest and the position", () =>
            {
                var e = Assert.Throws<ManifestException>(() => Parse(Sample.Substring(0, 200)), "truncated");
                Assert.Contains(ManifestPath + ": not valid JSON: line ", e.Message, "message");
            });
            t.Check("parser: top-level array is rejected", () => Assert.Throws<ManifestException>(() => Parse("[1]"), "array"));

            // ---- plan
            t.Check("plan: levels, paths, heights and fade settings", () =>
            {
                TilePlan plan = PlanSample(m => { });
                Assert.Equal(0, plan.Failures.Length, "failures");
                Assert.Equal("tiles/15_279418_116113", plan.Folder, "folder");
                Assert.Equal("15_279418_116113", plan.TileName, "tile name");
                Assert.Equal(PlacementMode.TileRelative, plan.Mode, "mode");
                Assert.Equal(LodFadeKind.CrossFade, plan.FadeMode, "fade");
                Assert.True(plan.AnimateCrossFading, "animate");
                BuildingPlan b1 = plan.Buildings[0];
                Assert.Equal("B1", b1.Name, "name");
                Assert.Equal("tiles/15_279418_116113/B1/lod1.glb", b1.Levels[1].Path, "path");
                Assert.Equal("B1/lod1.glb", b1.Levels[1].File, "file");
                Assert.Equal(0.5, b1.Levels[0].ScreenRelativeHeight, "h0");
                Assert.Equal(0.17, b1.Levels[1].ScreenRelativeHeight, "h1");
                Assert.Equal(0.02, b1.Levels[2].ScreenRelativeHeight, "h2");
                Assert.Equal(0.25, b1.Levels[2].FadeTransitionWidth, "fade width");
                Assert.Equal(1, b1.Problems.Length, "problems carried");
            });
            t.Check("plan: a building with fewer levels keeps its last one down to the culling height", () =>
            {
                BuildingPlan b2 = PlanSample(m => { }).Buildings[1];
                Assert.Equal("B_2_eef514d5", b2.Name, "safe name of B/2");
                Assert.Equal(2, b2.Levels.Length, "levels");
                Assert.Equal(0.5, b2.Levels[0].ScreenRelativeHeight, "h0");
                Assert.Equal(0.02, b2.Levels[1].ScreenRelativeHeight, "last level at the tile's last height");
            });
            t.Check("plan: tile_relative uses tile.placement and relative_placement", () =>
            {
                TilePlan plan = PlanSample(m => { });
                Assert.Equal(1000.5, plan.TileRoot.px, "tile root x");
                Assert.Equal(2.0, plan.TileRoot.scale, "tile root scale");
                Assert.Equal(10.0, plan.Buildings[0].Local.px, "relative x");
                Assert.Equal(0.6, plan.Buildings[0].Local.qx, "relative qx");
            });
            t.Check("plan: globe mode uses identity root and the globe placement", () =>
            {
                TilePlan plan = PlanSample(m => m.globe.placement = "globe");
                Assert.Equal(PlacementMode.Globe, plan.Mode, "mode");
                Assert.Equal(0.0, plan.TileRoot.px, "root x");
                Assert.Equal(1.0, plan.TileRoot.qw, "root w");
                Assert.Equal(1.0, plan.TileRoot.scale, "root scale");
                Assert.Equal(1.0, plan.Buildings[0].Local.px, "globe x");
                Assert.Equal(5.0, plan.Buildings[1].Local.py, "globe y");
            });
            t.Check("plan: a manifest in the working folder gives bare paths", () =>
            {
                TilePlan plan = LodPlanner.Plan(Parse(Sample), "lod_manifest.json", p => !p.Contains("/") || p.StartsWith("B"));
                Assert.Equal("B1/lod0.glb", plan.Buildings[0].Levels[0].Path, "path");
            });

            // ---- tile-level validation
            t.Check("validate: heights not decreasing", () =>
            {
                var e = TileError(m => m.lod_group.screen_relative_heights = new[] { 0.5, 0.6, 0.02 });
                Assert.Equal("lod_group.screen_relative_heights[1]", e.Field, "field");
                Assert.Contains("strictly decrease", e.Message, "message");
            });
            t.Check("validate: equal heights", () => TileError(m => m.lod_group.screen_relative_heights = new[] { 0.5, 0.5 }));
            t.Check("validate: height 0 and above 1", () =>
            {
                TileError(m => m.lod_group.screen_relative_heights = new[] { 0.5, 0.0 });
                TileError(m => m.lod_group.screen_relative_heights = new[] { 1.5, 0.2 });
            });
            t.Check("validate: more than 8 levels", () =>
            {
                var e = TileError(m => m.lod_group.screen_relative_heights = Enumerable.Range(0, 9).Select(k => 0.9 - 0.1 * k).ToArray());
                Assert.Contains("at most 8", e.Message, "message");
            });
            t.Check("validate: 8 levels are fine", () =>
            {
                TilePlan plan = PlanSample(m => m.lod_group.screen_relative_heights = Enumerable.Range(0, 8).Select(k => 0.9 - 0.1 * k).ToArray());
                Assert.Near(0.2, plan.Buildings[0].Levels[2].ScreenRelativeHeight, 1e-12, "last level of B1 at the 8th height");
            });
            t.Check("validate: no heights", () => Assert.Equal("lod_group.screen_relative_heights", TileError(m => m.lod_group.screen_relative_heights = new double[0]).Field, "field"));
            t.Check("validate: wrong format", () => Assert.Equal("format", TileError(m => m.format = "something-else").Field, "field"));
            t.Check("validate: unsupported major version", () => Assert.Equal("version", TileError(m => m.version = "2.0").Field, "field"));
            t.Check("validate: minor versions are read", () => PlanSample(m => m.version = "1.7"));
            t.Check("validate: unknown placement mode", () => Assert.Equal("globe.placement", TileError(m => m.globe.placement = "flat").Field, "field"));
            t.Check("validate: unknown fade mode", () => Assert.Equal("lod_group.fade_mode", TileError(m => m.lod_group.fade_mode = "CrossFade").Field, "field"));
            t.Check("validate: summary counts must match", () =>
            {
                Assert.Equal("summary.buildings", TileError(m => m.summary.buildings = 3).Field, "buildings");
                Assert.Equal("summary.skipped", TileError(m => m.summary.skipped = 0).Field, "skipped");
            });
            t.Check("validate: tile placement must be a unit quaternion", () =>
                Assert.Equal("tile.placement", TileError(m => m.tile.placement.rotation = new[] { 0, 0.6, 0, 0.9 }).Field, "field"));

            // ---- per-building validation: one failure, the rest still planned
            t.Check("validate: missing file fails only that building", () =>
            {
                TilePlan plan = LodPlanner.Plan(Parse(Sample), ManifestPath, p => SampleExists(p) && !p.EndsWith("B1/lod1.glb"));
                ManifestException e = OnlyFailure(plan);
                Assert.Equal("buildings[0] (id B1).lods[1].file", e.Field, "field");
                Assert.Contains("tiles/15_279418_116113/B1/lod1.glb does not exist", e.Message, "message");
                Assert.Equal(1, plan.Buildings.Length, "other building planned");
                Assert.Equal("B/2", plan.Buildings[0].Id, "survivor");
            });
            t.Check("validate: levels out of order", () =>
                Assert.Equal("buildings[0] (id B1).lods[1].level", OnlyFailure(PlanSample(m => m.buildings[0].lods[1].level = 2)).Field, "field"));
            t.Check("validate: more levels than heights", () =>
                Assert.Equal("buildings[0] (id B1).lods", OnlyFailure(PlanSample(m => m.lod_group.screen_relative_heights = new[] { 0.5, 0.1 })).Field, "field"));
            t.Check("validate: empty file name, absolute path, parent folder, not glTF", () =>
            {
                foreach (string file in new[] { "", "/abs/lod0.glb", "C:/x/lod0.glb", "../other/lod0.glb", "B1/lod0.obj" })
                {
                    string f = file;
                    ManifestException e = OnlyFailure(PlanSample(m => m.buildings[0].lods[0].file = f));
                    Assert.Equal("buildings[0] (id B1).lods[0].file", e.Field, "field for " + f);
                }
            });
            t.Check("validate: missing id", () =>
                Assert.Equal("buildings[1].id", OnlyFailure(PlanSample(m => m.buildings[1].id = "")).Field, "field"));
            t.Check("validate: duplicate ids (after making them safe)", () =>
                Assert.Equal("buildings[1] (id B1).id", OnlyFailure(PlanSample(m => m.buildings[1].id = "B1")).Field, "field"));
            t.Check("validate: building placement checked for the mode in use", () =>
            {
                Assert.Equal("buildings[0] (id B1).relative_placement",
                    OnlyFailure(PlanSample(m => m.buildings[0].relative_placement.scale = 0)).Field, "tile_relative");
                Assert.Equal("buildings[1] (id B/2).placement",
                    OnlyFailure(PlanSample(m => { m.globe.placement = "globe"; m.buildings[1].placement.position = new[] { 1.0, 2.0 }; })).Field, "globe");
            });
            t.Check("load: unreadable manifest names the path", () =>
            {
                string missing = Path.Combine(Path.GetTempPath(), "no-such-dir-vworldlod", "lod_manifest.json");
                var e = Assert.Throws<ManifestException>(() => LodPlanner.Load(missing, new PlainJsonManifestParser(), File.Exists), "missing file");
                Assert.Contains(missing + ": cannot read the manifest", e.Message, "message");
            });
            t.Check("safe names match exporter.names.safe_folder_name", () =>
            {
                Assert.Equal("B1", LodPlanner.SafeName("B1"), "kept");
                Assert.Equal("a_b_3ec69c85", LodPlanner.SafeName("a/b"), "slash");
                Assert.Equal("building_9d891e73", LodPlanner.SafeName(".."), "dots only");
                Assert.Equal("building_bf15be71", LodPlanner.SafeName("\u00e9"), "non-ascii");
                Assert.Equal(new string('x', 80) + "_6689f28c", LodPlanner.SafeName(new string('x', 100) + "/"), "long");
            });

            PoseTests.Run(t);
        }
    }
}
