// TileStreamer driven through a camera path over a multi-tile export written by the Python side
// (exporter.manifest + exporter.tile_index), with a fake backend whose loads complete one frame
// after they start: which tiles load and unload at each step (against the expectation computed in
// Python), the order of loads, the concurrency cap, cancellation and early destroy.
using System;
using System.Collections.Generic;
using System.IO;
using System.Linq;
using System.Threading;
using System.Threading.Tasks;

namespace VWorldLod.Tests
{
    public class FakeBackend : IStreamingBackend
    {
        public class Handle { public string What; public bool Released; }

        class Load
        {
            public int Frame;
            public Action<bool> Complete; // argument: whether to answer a cancelled load with null
            public CancellationToken Token;
        }

        readonly List<Load> pending = new List<Load>();
        public readonly List<Handle> Handles = new List<Handle>();
        public readonly List<string> Reports = new List<string>();
        public readonly List<string> Shown = new List<string>();
        public readonly List<string> UnloadedTiles = new List<string>();
        public readonly List<TilePlan> Plans = new List<TilePlan>();
        public int Frame;
        public bool Disposed;
        /// <summary>Loads that completed after their tile was unloaded (or the streamer destroyed).</summary>
        public int CompletedAfterCancel;
        /// <summary>Level files that fail to load (reported, answered with null).</summary>
        public readonly HashSet<string> BrokenLevels = new HashSet<string>();
        int answers;
        readonly string indexFolder;

        public FakeBackend(string indexFolder) { this.indexFolder = indexFolder; }

        public int Pending { get { return pending.Count; } }

        public Task<TilePlan> LoadTile(TileIndexEntry tile, CancellationToken cancellation)
        {
            var done = new TaskCompletionSource<TilePlan>();
            pending.Add(new Load
            {
                Frame = Frame,
                Token = cancellation,
                Complete = nullWhenCancelled =>
                {
                    if (cancellation.IsCancellationRequested && nullWhenCancelled) { done.SetResult(null); return; }
                    try
                    {
                        string path = Path.Combine(indexFolder, tile.manifest);
                        TilePlan plan = LodPlanner.Load(path, new PlainJsonManifestParser(), p => true);
                        foreach (ManifestException f in plan.Failures) Report(f.Message);
                        Plans.Add(plan);
                        done.SetResult(plan);
                    }
                    catch (ManifestException e)
                    {
                        Report(e.Message);
                        done.SetResult(null);
                    }
                },
            });
            return done.Task;
        }

        public Task<object> LoadLevel(TilePlan tile, BuildingPlan building, int level, CancellationToken cancellation)
        {
            var done = new TaskCompletionSource<object>();
            pending.Add(new Load
            {
                Frame = Frame,
                Token = cancellation,
                Complete = nullWhenCancelled =>
                {
                    if (cancellation.IsCancellationRequested) CompletedAfterCancel++;
                    if (BrokenLevels.Contains(building.Levels[level].Path))
                    {
                        Report(building.Levels[level].Path + ": glTFast could not load it");
                        done.SetResult(null);
                        return;
                    }
                    var handle = new Handle { What = building.Levels[level].Path };
                    Handles.Add(handle);
                    if (cancellation.IsCancellationRequested && nullWhenCancelled)
                    {
                        handle.Released = true; // the backend cleans up itself and answers null
                        done.SetResult(null);
                        return;
                    }
                    done.SetResult(handle);
                },
            });
            return done.Task;
        }

        /// <summary>Completes the loads started before this frame (cancelled ones alternately answered with null or a result).</summary>
        public void CompleteStartedBefore(int frame)
        {
            foreach (Load p in pending.Where(p => p.Frame < frame).ToList())
            {
                pending.Remove(p);
                p.Complete(answers++ % 2 == 0);
            }
        }

        public void ShowLevels(TilePlan tile, BuildingPlan building, int[] levels, object[] loaded)
        {
            if (Disposed) throw new TestFailure("ShowLevels after Dispose");
            for (int i = 0; i < levels.Length; i++)
            {
                if (i > 0 && levels[i] <= levels[i - 1]) throw new TestFailure("levels not ascending");
                var h = (Handle)loaded[i];
                if (h.Released || h.What != building.Levels[levels[i]].Path) throw new TestFailure("wrong or released handle for " + building.Id + " level " + levels[i]);
            }
            LodPlanner.LoadedHeights(building, levels);
            Shown.Add(tile.TileName + " " + building.Id + " " + string.Join(",", levels));
        }

        public void ReleaseLevel(object loaded)
        {
            var h = (Handle)loaded;
            if (h.Released) throw new TestFailure("released twice: " + h.What);
            h.Released = true;
        }

        public void UnloadTile(TilePlan tile) { UnloadedTiles.Add(tile.TileName); }

        public void Report(string message) { Reports.Add(message); }
    }

    public static class StreamingTests
    {
        static List<object> L(object o) { return (List<object>)o; }
        static Dictionary<string, object> D(object o) { return (Dictionary<string, object>)o; }

        /// <summary>
        /// path: {"index": tiles.json path, "origin": {lon, lat, elev}, "settings": {load, unload, max},
        /// "camera": [[x, y, z]...], "expected": [{"load": [...], "unload": [...]}] per step,
        /// "broken": tile name whose manifest is broken}.
        /// </summary>
        public static void Run(TestRunner t, string path)
        {
            var spec = D(PlainJson.Parse(File.ReadAllText(path)));
            string indexPath = (string)spec["index"];
            var o = D(spec["origin"]);
            var origin = new GeoOrigin((double)o["lon"], (double)o["lat"], (double)o["elev"]);
            var s = D(spec["settings"]);
            var settings = new StreamingSettings { LoadRadius = (double)s["load"], UnloadRadius = (double)s["unload"], MaxConcurrentLoads = (int)(double)s["max"] };
            var camera = L(spec["camera"]).Select(p => L(p).Select(v => (double)v).ToArray()).ToList();
            var expected = L(spec["expected"]).Select(D).ToList();
            string broken = (string)spec["broken"];

            var problems = new List<string>();
            TileIndexEntry[] tiles = null;
            t.Check("streaming: reads the generated tiles.json", () =>
            {
                tiles = TileIndexReader.Read(File.ReadAllText(indexPath), indexPath, json => PlainJsonManifestParser.ParseAs<TileIndex>(json, indexPath), problems);
                Assert.True(tiles.Length >= 9, "tiles: " + tiles.Length);
                Assert.Equal(0, problems.Count, "problems");
            });
            if (tiles == null) return;
            string folder = Path.GetDirectoryName(indexPath);

            t.Check("streaming: camera path loads and unloads the expected tiles, step by step", () =>
            {
                var backend = new FakeBackend(folder);
                string brokenLevel = Path.Combine(folder, tiles[7].name, "B1", "lod1.glb").Replace('\\', '/');
                backend.BrokenLevels.Add(brokenLevel);
                var streamer = new TileStreamer(tiles, e => e.ScenePosition(origin), settings, backend);
                var events = new List<string>();
                streamer.OnEvent = events.Add;
                var requestsByTile = new Dictionary<string, List<string>>();
                int settled = 0;
                for (int step = 0; step < camera.Count; step++)
                {
                    events.Clear();
                    backend.Frame = step;
                    backend.CompleteStartedBefore(step);
                    double[] c = camera[step];
                    streamer.Update(c[0], c[1], c[2]);
                    Assert.True(streamer.InFlight <= settings.MaxConcurrentLoads, "in flight " + streamer.InFlight + " at step " + step);
                    var loads = events.Where(e => e.StartsWith("load ")).Select(e => e.Substring(5)).ToList();
                    var unloads = events.Where(e => e.StartsWith("unload ")).Select(e => e.Substring(7)).ToList();
                    var wantLoads = L(expected[step]["load"]).Cast<string>().ToList();
                    var wantUnloads = L(expected[step]["unload"]).Cast<string>().ToList();
                    Assert.Equal(string.Join(" ", wantUnloads.OrderBy(x => x)), string.Join(" ", unloads.OrderBy(x => x)), "unloads at step " + step);
                    Assert.Equal(string.Join(" ", wantLoads.OrderBy(x => x)), string.Join(" ", loads.OrderBy(x => x)), "loads at step " + step);
                    for (int i = 1; i < loads.Count; i++)
                    {
                        TileIndexEntry a = tiles.First(x => x.name == loads[i - 1]), b = tiles.First(x => x.name == loads[i]);
                        Assert.True(Dist(a.ScenePosition(origin), c) <= Dist(b.ScenePosition(origin), c), "loads nearest first at step " + step);
                    }
                    foreach (string e in events.Where(e => e.StartsWith("request ")))
                    {
                        string[] parts = e.Split(' ');
                        List<string> list;
                        if (!requestsByTile.TryGetValue(parts[1], out list)) requestsByTile[parts[1]] = list = new List<string>();
                        list.Add(e);
                    }
                    // A still camera: once loads have settled every building holds exactly the
                    // level its LODGroup shows at its distance (nothing when culled).
                    bool still = step >= 10 && Enumerable.Range(step - 10, 10).All(i => camera[i].SequenceEqual(c));
                    if (!still) continue;
                    settled++;
                    foreach (TilePlan plan in backend.Plans.Where(p => streamer.LoadedTiles().Contains(p.TileName)))
                    {
                        double[] at = tiles.First(x => x.name == plan.TileName).ScenePosition(origin);
                        foreach (BuildingPlan b in plan.Buildings)
                        {
                            double dx = at[0] + b.Relative.px - c[0], dy = at[1] + b.Relative.py - c[1], dz = at[2] + b.Relative.pz - c[2];
                            double h = 30 / (2 * Math.Sqrt(dx * dx + dy * dy + dz * dz) * Math.Tan(Math.PI / 6)); // no bounds: 30 m; 60 degrees
                            bool brokenOne = plan.TileName == tiles[7].name && b.Id == "B1"; // its LOD1 is broken: LOD2 stands in
                            Func<double, int> shown = r =>
                            {
                                int k = Array.FindIndex(b.Levels, l => r >= l.ScreenRelativeHeight);
                                return brokenOne && k == 1 ? 2 : k;
                            };
                            int want = shown(h);
                            List<int> resident = streamer.ResidentLevels(plan.TileName, b.Id);
                            string where = plan.TileName + " " + b.Id + " at step " + step + " (h " + h + "): " + string.Join(",", resident);
                            Assert.True(want < 0 || resident.Contains(want), where + " holds level " + want);
                            // Besides it, only a level within the keep factor of being needed, or the next
                            // finer one prefetched when the camera came closer (the default factors).
                            double keep = new StreamingSettings().KeepFactor, ahead = new StreamingSettings().PrefetchFactor;
                            Assert.True(resident.All(k => k == want || k == shown(h * keep) || k == shown(h / keep) || (k == want - 1 && k == shown(h * ahead))), where + " holds nothing else");
                        }
                    }
                }
                Assert.True(settled > 0, "the path has a pause");
                Assert.Equal(settings.MaxConcurrentLoads, streamer.MaxInFlightSeen, "the cap is reached and never passed");
                // Per tile: the manifest first; levels only after it.
                int levelRequests = 0;
                foreach (var pair in requestsByTile)
                {
                    bool manifestFirst = pair.Value[0] == "request " + pair.Key;
                    Assert.True(manifestFirst, pair.Key + ": manifest requested first");
                    levelRequests += pair.Value.Count(e => e.Split(' ').Length == 4);
                }
                Assert.True(levelRequests > 0, "levels were requested");
                Assert.True(backend.Shown.Count > 0, "buildings were shown");
                Assert.True(backend.Reports.Any(r => r.Contains(broken) && r.Contains("not valid JSON")), "the broken manifest is reported by name: " + string.Join(" | ", backend.Reports));
                Assert.True(backend.Shown.Any(x => !x.StartsWith(broken)), "other tiles still load");
                Assert.True(backend.Reports.Any(r => r.StartsWith(brokenLevel)), "the broken level is reported by name: " + brokenLevel);
                Assert.True(backend.Shown.Contains(tiles[7].name + " B1 2"), "its building shows LOD2 instead: " + string.Join(" | ", backend.Shown.Where(x => x.StartsWith(tiles[7].name + " B1"))));

                // Away with loads in flight: they finish after their tiles are unloaded, and
                // everything that came back is released.
                Assert.True(streamer.InFlight > 0, "loads in flight at the end of the path");
                streamer.Update(1e9, 0, 0);
                for (int frame = camera.Count; backend.Pending > 0 || streamer.InFlight > 0 || streamer.Draining > 0; frame++)
                {
                    backend.Frame = frame;
                    backend.CompleteStartedBefore(frame);
                    streamer.Update(1e9, 0, 0);
                    if (frame > camera.Count + 10) throw new TestFailure("loads never finished");
                }
                Assert.Equal(0, streamer.LoadedTiles().Count, "no tile left loaded");
                Assert.True(backend.CompletedAfterCancel > 0, "some loads finished after their tile was unloaded (mid-load unloads exercised)");
                var leaked = backend.Handles.Where(h => !h.Released).Select(h => h.What).ToList();
                Assert.True(leaked.Count == 0, "unreleased levels: " + string.Join(", ", leaked));
                streamer.Dispose();
            });

            t.Check("streaming: early destroy with loads in flight throws nothing and frees everything", () =>
            {
                var backend = new FakeBackend(folder);
                var streamer = new TileStreamer(tiles, e => e.ScenePosition(origin), settings, backend);
                double[] c = { 0, 30, 0 }; // the georeference origin: among the tiles
                for (int frame = 0; frame < 4; frame++)
                {
                    backend.Frame = frame;
                    backend.CompleteStartedBefore(frame);
                    streamer.Update(c[0], c[1], c[2]);
                }
                Assert.True(backend.Pending > 0 && backend.Shown.Count > 0, "destroyed mid-load");
                streamer.Dispose();
                backend.Disposed = true;
                streamer.Dispose(); // twice: still nothing
                streamer.Update(c[0], c[1], c[2]); // after destroy: ignored
                backend.CompleteStartedBefore(int.MaxValue);
                var leaked = backend.Handles.Where(h => !h.Released).Select(h => h.What).ToList();
                Assert.True(leaked.Count == 0, "unreleased levels: " + string.Join(", ", leaked));
                Assert.True(backend.UnloadedTiles.Count > 0, "tile roots removed");
            });

            t.Check("streaming: moving the origin re-places tile centres (Reposition)", () =>
            {
                var backend = new FakeBackend(folder);
                GeoOrigin current = origin;
                var streamer = new TileStreamer(tiles, e => e.ScenePosition(current), settings, backend);
                var events = new List<string>();
                streamer.OnEvent = events.Add;
                TileIndexEntry far = tiles.OrderBy(e => Dist(e.ScenePosition(origin), new double[3])).Last();
                streamer.Update(0, 0, 0);
                Assert.True(!events.Contains("load " + far.name), "the far tile is not loaded around the origin");
                current = new GeoOrigin(far.center.lon, far.center.lat, far.center.elev);
                streamer.Reposition();
                events.Clear();
                streamer.Update(0, 0, 0); // same camera position, new origin: now at the far tile
                Assert.True(events.Contains("load " + far.name), "the far tile loads after the origin moved: " + string.Join(", ", events));
                streamer.Dispose();
            });
        }

        static double Dist(double[] a, double[] b)
        {
            return Math.Sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) + (a[2] - b[2]) * (a[2] - b[2]));
        }

        /// <summary>Self-contained checks of the streamer's inputs: bad tile indexes, settings, URLs.</summary>
        public static void RunSelfContained(TestRunner t)
        {
            const string good = @"{""format"": ""vworld-lod-tile-index"", ""version"": ""1.0"", ""tiles"": [
 {""name"": ""15_1_1"", ""level"": 15, ""idx"": 1, ""idy"": 1, ""center"": {""lon"": 1, ""lat"": 2, ""elev"": 0},
  ""manifest"": ""15_1_1/lod_manifest.json"", ""buildings"": 2, ""globe"": {""earth_radius_m"": 6378137, ""unity_radius"": 6378137}, ""future"": 1},
 {""name"": ""15_1_2"", ""level"": 15, ""idx"": 1, ""idy"": 2, ""center"": {""lon"": 1, ""lat"": 95, ""elev"": 0},
  ""manifest"": ""15_1_2/lod_manifest.json"", ""buildings"": 2, ""globe"": {""earth_radius_m"": 6378137, ""unity_radius"": 6378137}},
 {""name"": ""15_1_3"", ""level"": 15, ""idx"": 1, ""idy"": 3, ""center"": {""lon"": 1, ""lat"": 3, ""elev"": 0},
  ""manifest"": ""../secret.json"", ""buildings"": 2, ""globe"": {""earth_radius_m"": 6378137, ""unity_radius"": 6378137}}]}";
            Func<string, TileIndex> parse = json => PlainJsonManifestParser.ParseAs<TileIndex>(json, "x/tiles.json");
            t.Check("tile index: a bad entry is left out and named, the others kept", () =>
            {
                var problems = new List<string>();
                TileIndexEntry[] tiles = TileIndexReader.Read(good, "x/tiles.json", parse, problems);
                Assert.Equal(1, tiles.Length, "usable tiles");
                Assert.Equal(2, problems.Count, "problems");
                Assert.Contains("x/tiles.json: tiles[1] (15_1_2): center", problems[0], "pole-crossing centre");
                Assert.Contains("leaves the index's folder", problems[1], "path escaping the export");
            });
            foreach (string[] bad in new[]
            {
                new[] { "", "the tile index is empty" },
                new[] { "{\"format\": \"vworld-lod-tile-index\", \"version\": \"1.0\", \"tiles\": [", "not valid JSON" },
                new[] { "{\"format\": \"vworld-lod-manifest\", \"version\": \"1.0\"}", "format" },
                new[] { "{\"format\": \"vworld-lod-tile-index\", \"version\": \"2.0\"}", "version \"2.0\" is not supported" },
            })
            {
                string[] b = bad;
                t.Check("tile index: refuses " + (b[0].Length == 0 ? "an empty file" : b[1]), () =>
                {
                    var e = Assert.Throws<ManifestException>(() => TileIndexReader.Read(b[0], "x/tiles.json", parse, new List<string>()), "broken index");
                    Assert.True(e.Message.StartsWith("x/tiles.json: "), "names the file: " + e.Message);
                    Assert.Contains(b[1], e.Message, "says what");
                });
            }
            t.Check("streaming settings: unload radius below load radius and no concurrency are refused", () =>
            {
                Assert.Contains("unload radius", new StreamingSettings { LoadRadius = 100, UnloadRadius = 50 }.Problem(), "radii");
                Assert.Contains("concurrent", new StreamingSettings { MaxConcurrentLoads = 0 }.Problem(), "cap");
                Assert.True(new StreamingSettings().Problem() == null, "defaults are fine");
                Assert.Throws<ArgumentException>(() => new TileStreamer(new TileIndexEntry[0], e => new double[3], new StreamingSettings { MaxConcurrentLoads = 0 }, new FakeBackend(".")), "constructor");
            });
            t.Check("streaming: horizontal distances ignore the camera's height", () =>
            {
                var tiles = TileIndexReader.Read(good, "x/tiles.json", parse, new List<string>());
                foreach (bool horizontal in new[] { false, true })
                {
                    var streamer = new TileStreamer(tiles, e => new double[] { 10, -40, 0 }, new StreamingSettings { LoadRadius = 100, UnloadRadius = 120, Horizontal = horizontal }, new FakeBackend("."));
                    var events = new List<string>();
                    streamer.OnEvent = events.Add;
                    streamer.Update(0, 400, 0); // 440 above the tile centre, 10 beside it
                    Assert.Equal(horizontal, events.Contains("load 15_1_1"), "loaded with Horizontal = " + horizontal);
                    streamer.Dispose();
                }
            });
            t.Check("streaming paths: StreamingAssets, absolute folders, http(s) and Android URLs", () =>
            {
                Assert.Equal("https://example.org/city/tiles.json", StreamingPaths.Resolve("https://example.org/city/", "/sa", "tiles.json"), "http folder");
                Assert.Equal("https://example.org/city/tiles.json", StreamingPaths.Resolve("https://example.org/city/tiles.json", "/sa", "tiles.json"), "http file");
                Assert.Equal("file:///sa/city/tiles.json", StreamingPaths.Resolve("city", "/sa", "tiles.json"), "StreamingAssets folder");
                Assert.Equal("file:///data/export/tiles.json", StreamingPaths.Resolve("/data/export", "/sa", "tiles.json"), "absolute folder");
                Assert.Equal("jar:file:///app.apk!/assets/city/tiles.json", StreamingPaths.Resolve("city/tiles.json", "jar:file:///app.apk!/assets", "tiles.json"), "Android");
                Assert.Equal("https://example.org/city/15_1_1/lod_manifest.json", StreamingPaths.Beside("https://example.org/city/tiles.json", "15_1_1/lod_manifest.json"), "manifest beside the index");
            });
            t.Check("streaming paths: a signed URL keeps its query on the index, manifests, proxies and levels", () =>
            {
                const string index = "https://cdn.example.org/city/tiles.json?sig=a/b%3D&exp=9";
                Assert.Equal(index, StreamingPaths.Resolve(index, "/sa", "tiles.json"), "the index as given");
                Assert.Equal(index, StreamingPaths.Resolve("https://cdn.example.org/city/?sig=a/b%3D&exp=9", "/sa", "tiles.json"), "a folder URL with a query");
                string manifest = StreamingPaths.Beside(index, "15_279418_116113/lod_manifest.json");
                Assert.Equal("https://cdn.example.org/city/15_279418_116113/lod_manifest.json?sig=a/b%3D&exp=9", manifest, "manifest");
                Assert.Equal("https://cdn.example.org/city/tileset_proxies/15_1_1.glb?sig=a/b%3D&exp=9", StreamingPaths.Beside(index, "tileset_proxies/15_1_1.glb"), "proxy");
                TilePlan plan = StreamingPaths.PlanAt(PlanTests.Parse(PlanTests.Sample), manifest);
                Assert.True(plan.Buildings.Length > 0, "planned");
                foreach (BuildingPlan b in plan.Buildings)
                    foreach (LevelPlan level in b.Levels)
                        Assert.True(level.Path.StartsWith("https://cdn.example.org/city/15_279418_116113/") && level.Path.EndsWith(".glb?sig=a/b%3D&exp=9"), "level URL: " + level.Path);
                Assert.Equal("https://cdn.example.org/city/15_279418_116113/lod_manifest.json", plan.ManifestPath, "errors name the manifest without the signature");
                Assert.Equal("file:///sa/city/tiles.json", StreamingPaths.Resolve("city", "/sa", "tiles.json"), "paths without a query unchanged");
            });
            t.Check("streaming: a backend that throws or faults is reported, never thrown", () =>
            {
                var tiles = TileIndexReader.Read(good, "x/tiles.json", parse, new List<string>());
                var backend = new ThrowingBackend();
                var streamer = new TileStreamer(tiles, e => new double[3], new StreamingSettings(), backend);
                streamer.Update(0, 0, 0);
                streamer.Update(0, 0, 0);
                streamer.Dispose();
                Assert.True(backend.Reports.Any(r => r.Contains("15_1_1/lod_manifest.json") && r.Contains("disk on fire")), "reported with the file: " + string.Join(" | ", backend.Reports));
            });
        }

        class ThrowingBackend : IStreamingBackend
        {
            public readonly List<string> Reports = new List<string>();
            public Task<TilePlan> LoadTile(TileIndexEntry tile, CancellationToken c) { throw new IOException("disk on fire"); }
            public Task<object> LoadLevel(TilePlan tile, BuildingPlan b, int level, CancellationToken c) { throw new IOException("disk on fire"); }
            public void ShowLevels(TilePlan tile, BuildingPlan b, int[] levels, object[] loaded) { throw new IOException("disk on fire"); }
            public void ReleaseLevel(object loaded) { throw new IOException("disk on fire"); }
            public void UnloadTile(TilePlan tile) { throw new IOException("disk on fire"); }
            public void Report(string message) { Reports.Add(message); }
        }
    }
}
