// ProxyStreamer (the tileset's HLOD proxies beyond the building radius): selection by
// screen-space error coarse to fine, the coarser proxy holding until its finer ones arrive, no
// proxy over a tile that shows its buildings, the load cap, cancellation and release; and over a
// real export's tiles.json (written by the Python side) together with TileStreamer.
using System;
using System.Collections.Generic;
using System.IO;
using System.Linq;
using System.Threading;
using System.Threading.Tasks;

namespace VWorldLod.Tests
{
    public class FakeProxyBackend : IProxyBackend
    {
        public class Handle { public string Name; public bool Released, Visible; }

        readonly List<Action> pending = new List<Action>();
        public readonly List<Handle> Handles = new List<Handle>();
        public readonly List<string> Reports = new List<string>();
        public readonly HashSet<string> Broken = new HashSet<string>();
        public readonly string Folder;

        public FakeProxyBackend(string folder = null) { Folder = folder; }

        public int Pending { get { return pending.Count; } }

        /// <summary>The mipmapLimit of each load asked, in order ("name:limit").</summary>
        public readonly List<string> Limits = new List<string>();

        public Task<object> LoadProxy(ProxyEntry proxy, int mipmapLimit, CancellationToken cancellation)
        {
            Limits.Add(proxy.name + ":" + mipmapLimit);
            var done = new TaskCompletionSource<object>();
            pending.Add(() =>
            {
                if (Broken.Contains(proxy.name) || (Folder != null && !File.Exists(Path.Combine(Folder, proxy.file))))
                {
                    Reports.Add(proxy.file + ": glTFast could not load it");
                    done.SetResult(null);
                    return;
                }
                var h = new Handle { Name = proxy.name };
                Handles.Add(h);
                done.SetResult(h);
            });
            return done.Task;
        }

        public void CompleteAll()
        {
            var now = pending.ToList();
            pending.Clear();
            foreach (Action a in now) a();
        }

        public void ShowProxy(object loaded, bool visible)
        {
            var h = (Handle)loaded;
            if (h.Released) throw new TestFailure("showing a released proxy: " + h.Name);
            h.Visible = visible;
        }

        /// <summary>Texture bytes each loaded proxy reports (the budget's accounting).</summary>
        public long BytesEach = 1000;

        public long TextureBytes(object loaded) { return BytesEach; }

        public void ReleaseProxy(object loaded)
        {
            var h = (Handle)loaded;
            if (h.Released) throw new TestFailure("released twice: " + h.Name);
            h.Released = true;
            h.Visible = false;
        }

        public void Report(string message) { Reports.Add(message); }

        /// <summary>Names of the proxies whose handles are shown now, sorted.</summary>
        public string Drawn() { return string.Join(" ", Handles.Where(h => h.Visible && !h.Released).Select(h => h.Name).OrderBy(n => n)); }
    }

    public static class ProxyTests
    {
        static readonly GlobeInfo Earth = new GlobeInfo { earth_radius_m = 6378137, unity_radius = 6378137 };

        static ProxyEntry P(string name, int level, double radius, double error, string[] children, string[] tiles)
        {
            return new ProxyEntry
            {
                name = name, level = level, radius_m = radius, geometric_error = error, children = children, tiles = tiles,
                file = "tileset_proxies/" + name + ".glb", globe = Earth, center = new GeoCenter(),
                placement = new PlacementData { position = new double[3], rotation = new double[] { 0, 0, 0, 1 }, scale = 1 },
            };
        }

        // R over A and B (50 m either side); C far away on its own. Screen 1000 px, fov 90 degrees:
        // SSE = 500 error / d, so R (8 m, radius 150 m) refines closer than 400 m from its centre.
        public static ProxyEntry[] Tree()
        {
            return new[]
            {
                P("R", 14, 150, 8, new[] { "A", "B" }, new string[0]),
                P("A", 15, 60, 4, new string[0], new[] { "ta" }),
                P("B", 15, 60, 4, new string[0], new[] { "tb" }),
                P("C", 13, 100, 20, new string[0], new[] { "tc" }),
            };
        }

        public static readonly Dictionary<string, double[]> At = new Dictionary<string, double[]>
        {
            { "R", new double[] { 0, 0, 0 } }, { "A", new double[] { -50, 0, 0 } }, { "B", new double[] { 50, 0, 0 } }, { "C", new double[] { 5000, 0, 0 } },
        };

        static string Frame(ProxyStreamer s, FakeProxyBackend b, double x, double y, double z)
        {
            s.Update(x, y, z, 1000, 90);
            NoDoubleDrawing(s);
            b.CompleteAll();
            return b.Drawn();
        }

        static void NoDoubleDrawing(ProxyStreamer s)
        {
            var visible = new HashSet<string>(s.Visible());
            if (visible.Contains("R") && (visible.Contains("A") || visible.Contains("B")))
                throw new TestFailure("a proxy and its child both shown: " + string.Join(" ", visible));
        }

        public static void RunSelfContained(TestRunner t)
        {
            t.Check("proxies: screen-space error is error * height / (distance * 2 tan(fov / 2))", () =>
            {
                Assert.Near(8.0, ProxyStreamer.ScreenSpaceError(16, 1000, 1000, 90), 1e-12, "16 m at 1 km, 1000 px, 90 degrees");
                Assert.Near(16 * 1080 / (500 * 2 * Math.Tan(Math.PI / 6)), ProxyStreamer.ScreenSpaceError(16, 500, 1080, 60), 1e-9, "60 degrees");
            });

            t.Check("proxies: far the root alone, nearer its children, the root holding until they arrive", () =>
            {
                var b = new FakeProxyBackend();
                var s = new ProxyStreamer(Tree(), p => At[p.name], new StreamingSettings { ProxyTextureScreenSpaceError = 16 }, b);
                var events = new List<string>();
                s.OnEvent = events.Add;
                Assert.Equal("", Frame(s, b, 0, 1000, 0), "nothing loaded yet");
                Assert.Equal("C R", string.Join(" ", s.Wanted().OrderBy(n => n)), "wanted from 1 km up");
                Assert.Equal("C R", Frame(s, b, 0, 1000, 0), "the root and the far proxy");
                events.Clear();
                Assert.Equal("C R", Frame(s, b, 0, 300, 0), "refined: the root holds while A and B load");
                Assert.Equal("A B C", string.Join(" ", s.Wanted().OrderBy(n => n)), "wanted from 300 m up");
                Assert.True(events.Contains("load A") && events.Contains("load B"), "A and B requested: " + string.Join(", ", events));
                Assert.Equal("A B C", Frame(s, b, 0, 300, 0), "finer proxies shown, the root gone");
                Assert.True(s.Loaded().IndexOf("R") < 0, "the root is unloaded once replaced (no tile under it shows buildings)");
                Assert.True(b.Handles.Single(h => h.Name == "R").Released, "its handle released");
                Assert.Equal(3000, s.Budget.Resident, "texture bytes of the 3 loaded proxies");
                s.Dispose();
                Assert.True(b.Handles.All(h => h.Released), "Dispose releases every proxy");
                Assert.Equal(0, s.Budget.Resident, "nothing resident after Dispose");
            });

            t.Check("proxies: finest texture mip levels left out while the texel, bounded by the error, stays within the limit; loaded finer as the camera comes closer, the coarser copy shown until then", () =>
            {
                Assert.Equal(3, ProxyStreamer.MipmapLimit(2, 16), "2 px error under a 16 px limit: 3 levels (16 px texels)");
                Assert.Equal(0, ProxyStreamer.MipmapLimit(16, 16), "at the limit: none");
                Assert.Equal(0, ProxyStreamer.MipmapLimit(20, 16), "above it: none");
                Assert.Equal(0, ProxyStreamer.MipmapLimit(1, 0), "limit 0: none");
                Assert.Equal(ProxyStreamer.MaxMipmapLimit, ProxyStreamer.MipmapLimit(1e-9, 16), "capped");
                // C: 20 m error, radius 100 m, 5 km east; 1000 px, 90 degrees: SSE = 20 x 500 / d.
                var b = new FakeProxyBackend();
                var s = new ProxyStreamer(Tree(), p => At[p.name], new StreamingSettings { ProxyTextureScreenSpaceError = 16 }, b);
                var events = new List<string>();
                s.OnEvent = events.Add;
                Frame(s, b, 0, 0, 0);
                Assert.True(Frame(s, b, 0, 0, 0).Contains("C"), "C shown");
                Assert.Equal(2, s.LoadedMipmapLimit("C"), "C 4.9 km away (2 px): 2 levels left out");
                Assert.True(b.Limits.Contains("C:2"), "asked of the backend: " + string.Join(" ", b.Limits));
                Assert.True(Frame(s, b, 4000, 0, 0).Contains("C"), "near C: C still shown while its finer copy loads");
                Assert.True(events.Contains("load finer C"), "a finer C requested: " + string.Join(", ", events));
                Assert.Equal(2, s.LoadedMipmapLimit("C"), "the coarse copy stays until the finer one arrives");
                Assert.True(Frame(s, b, 4000, 0, 0).Contains("C"), "the finer copy takes its place");
                Assert.Equal(0, s.LoadedMipmapLimit("C"), "C 900 m away (11 px): whole");
                Assert.Equal(1, b.Handles.Count(h => h.Name == "C" && !h.Released), "the coarse copy released");
                Assert.True(b.Handles.Single(h => h.Name == "C" && !h.Released).Visible, "the finer copy shown");
                Assert.Equal(1000L * s.Loaded().Count, s.Budget.Resident, "the coarse copy's bytes left the budget");
                s.Dispose();

                // tiles.json's texel_m (the atlas's own texel, here 1/8 of the 20 m error) decides
                // instead of the error that bounds it: 3 more levels left out at the same distance.
                ProxyEntry[] stated = Tree();
                foreach (ProxyEntry e in stated) if (e.name == "C") e.texel_m = 2.5;
                var bt = new FakeProxyBackend();
                var st = new ProxyStreamer(stated, p => At[p.name], new StreamingSettings { ProxyTextureScreenSpaceError = 16 }, bt);
                Frame(st, bt, 0, 0, 0);
                Frame(st, bt, 0, 0, 0);
                Assert.Equal(5, st.LoadedMipmapLimit("C"), "C's 2.5 m texel 4.9 km away (0.25 px): 5 levels left out");
                st.Dispose();

                var whole = new FakeProxyBackend();
                var w = new ProxyStreamer(Tree(), p => At[p.name], new StreamingSettings { ProxyTextureScreenSpaceError = 0 }, whole);
                Frame(w, whole, 0, 0, 0);
                Assert.True(whole.Limits.Contains("C:0"), "ProxyTextureScreenSpaceError 0: whole textures: " + string.Join(" ", whole.Limits));
                w.Dispose();
            });

            t.Check("proxies: a coarse proxy is refined where its children, leaving out more mip levels, hold less texture memory, and stays refined until they would hold twice its", () =>
            {
                // P (30 m error, radius 300 m) over Q1 and Q2 (15 m, radius 100 m at -150 / +150 m);
                // 1000 px, 90 degrees. From 2 km: P at 8.8 px may show but keeps its whole atlas,
                // Q1 and Q2 at 3.9 px leave out 2 levels each: 2/16 of P's bytes. From 1.5 km: P
                // at 12.5 px whole, Q at 5.3 px leave out 1: 2/4, not under half, within twice.
                var tree = new[]
                {
                    P("P", 14, 300, 30, new[] { "Q1", "Q2" }, new string[0]),
                    P("Q1", 15, 100, 15, new string[0], new[] { "t1" }),
                    P("Q2", 15, 100, 15, new string[0], new[] { "t2" }),
                };
                var at = new Dictionary<string, double[]> { { "P", new double[] { 0, 0, 0 } }, { "Q1", new double[] { -150, 0, 0 } }, { "Q2", new double[] { 150, 0, 0 } } };
                var b = new FakeProxyBackend();
                var s = new ProxyStreamer(tree, p => at[p.name], new StreamingSettings { ProxyTextureScreenSpaceError = 16 }, b);
                s.Update(0, 0, 2000, 1000, 90);
                Assert.Equal("Q1 Q2", string.Join(" ", s.Wanted()), "from 2 km: the lighter children wanted");
                s.Update(0, 0, 1500, 1000, 90);
                Assert.Equal("Q1 Q2", string.Join(" ", s.Wanted()), "from 1.5 km: still refined (no loading back and forth)");
                s.Dispose();
                var fresh = new FakeProxyBackend();
                var f = new ProxyStreamer(tree, p => at[p.name], new StreamingSettings { ProxyTextureScreenSpaceError = 16 }, fresh);
                f.Update(0, 0, 1500, 1000, 90);
                Assert.Equal("P", string.Join(" ", f.Wanted()), "from 1.5 km, not refined before: P");
                f.Dispose();
                var whole = new FakeProxyBackend();
                var w = new ProxyStreamer(tree, p => at[p.name], new StreamingSettings { ProxyTextureScreenSpaceError = 0 }, whole);
                w.Update(0, 0, 2000, 1000, 90);
                Assert.Equal("P", string.Join(" ", w.Wanted()), "whole textures: the coarsest within the error limit, as before");
                w.Dispose();
                // tiles.json's atlas_px (since 0.6.0 each proxy's atlas is as large as its error needs)
                Func<int, int, double, string> sized = (parent, child, distance) =>
                {
                    foreach (ProxyEntry e in tree) e.atlas_px = e.name == "P" ? parent : child;
                    var sb = new FakeProxyBackend();
                    var ss = new ProxyStreamer(tree, p => at[p.name], new StreamingSettings { ProxyTextureScreenSpaceError = 16 }, sb);
                    ss.Update(0, 0, distance, 1000, 90);
                    string names = string.Join(" ", ss.Wanted());
                    ss.Dispose();
                    return names;
                };
                Assert.Equal("Q1 Q2", sized(2048, 512, 1500), "from 1.5 km: Q1 and Q2's 512-texel atlases, 1 level left out, hold 1/32 of P's 2048 texels");
                Assert.Equal("P", sized(512, 2048, 2000), "from 2 km: Q1 and Q2's 2048-texel atlases, 2 levels left out, hold twice P's whole 512");
            });

            t.Check("proxies: the coarser proxy holds over shown buildings while a finer one loads; Covers names the tiles under shown proxies", () =>
            {
                var b = new FakeProxyBackend();
                var s = new ProxyStreamer(Tree(), p => At[p.name], new StreamingSettings { ProxyTextureScreenSpaceError = 16 }, b);
                var shown = new HashSet<string>();
                s.TileShown = shown.Contains;
                Frame(s, b, 0, 1000, 0);
                Assert.Equal("C R", Frame(s, b, 0, 1000, 0), "from far");
                Assert.True(s.Covers("ta") && s.Covers("tb") && s.Covers("tc"), "every tile under a shown proxy");
                shown.Add("ta"); // down at ta: its buildings show
                Assert.Equal("C R", Frame(s, b, 0, 300, 0), "the root holds over ta's buildings while B loads (drawn twice, no hole)");
                Assert.Equal("B C", Frame(s, b, 0, 300, 0), "B arrived");
                Assert.True(!s.Covers("ta") && s.Covers("tb"), "ta is under no shown proxy now");
                s.Dispose();
            });

            t.Check("proxies: the leaf proxy of a tile loading its buildings is not loaded while an ancestor stands in", () =>
            {
                var b = new FakeProxyBackend();
                var s = new ProxyStreamer(Tree(), p => At[p.name], new StreamingSettings { ProxyTextureScreenSpaceError = 16 }, b);
                var loading = new HashSet<string> { "ta", "tb" };
                s.TileLoading = loading.Contains;
                var events = new List<string>();
                s.OnEvent = events.Add;
                Frame(s, b, 0, 1000, 0);
                Assert.Equal("C R", Frame(s, b, 0, 1000, 0), "from far");
                for (int i = 0; i < 3; i++) Assert.Equal("C R", Frame(s, b, 0, 300, 0), "the root stands in while ta and tb load their buildings");
                Assert.True(!events.Contains("load A") && !events.Contains("load B"), "no leaf proxy loaded: " + string.Join(", ", events));
                loading.Remove("tb"); // tb's manifest failed: its proxy is needed after all
                Frame(s, b, 0, 300, 0);
                Assert.True(events.Contains("load B") && !events.Contains("load A"), "B loaded: " + string.Join(", ", events));
                s.Dispose();
            });

            t.Check("proxies: none is drawn over a tile that shows its buildings", () =>
            {
                var b = new FakeProxyBackend();
                var s = new ProxyStreamer(Tree(), p => At[p.name], new StreamingSettings { ProxyTextureScreenSpaceError = 16 }, b);
                var shown = new HashSet<string>();
                s.TileShown = shown.Contains;
                Frame(s, b, 0, 300, 0);
                Assert.Equal("A B C", Frame(s, b, 0, 300, 0), "before");
                shown.Add("ta");
                Assert.Equal("B C", Frame(s, b, 0, 300, 0), "A hidden where its buildings show");
                Assert.Equal("B C", Frame(s, b, 0, 5000, 0), "from far too: the root covers ta, so B stands alone");
                Assert.True(s.Loaded().IndexOf("A") < 0 && s.Loaded().IndexOf("R") < 0, "A and R not kept: " + string.Join(" ", s.Loaded()));
                shown.Clear();
                Frame(s, b, 0, 5000, 0);
                Assert.Equal("C R", Frame(s, b, 0, 5000, 0), "buildings gone: the root again");
                s.Dispose();
            });

            t.Check("proxies: loads capped, coarsest first; cancelled and failed loads handled", () =>
            {
                var b = new FakeProxyBackend();
                var s = new ProxyStreamer(Tree(), p => At[p.name], new StreamingSettings { MaxConcurrentLoads = 1 }, b);
                var events = new List<string>();
                s.OnEvent = events.Add;
                s.Update(0, 300, 0, 1000, 90);
                Assert.Equal("load C", string.Join(", ", events), "one load, the coarsest level first");
                Assert.Equal(1, s.InFlight, "in flight");
                b.CompleteAll();
                events.Clear();
                s.Update(0, 300, 0, 1000, 90);
                Assert.Equal("show C, load A", string.Join(", ", events), "then the nearer finer ones");
                s.Update(0, 5000, 0, 1000, 90); // away: A no longer wanted, its load cancelled
                b.CompleteAll();
                s.Update(0, 5000, 0, 1000, 90);
                Assert.True(b.Handles.Single(h => h.Name == "A").Released, "a load answered after it was cancelled is released");
                Assert.Equal(1, s.MaxInFlightSeen, "never more than the cap");
                s.Dispose();
                Assert.True(b.Handles.All(h => h.Released), "all released");

                var broken = new FakeProxyBackend();
                broken.Broken.Add("R");
                var t2 = new ProxyStreamer(Tree(), p => At[p.name], new StreamingSettings { ProxyTextureScreenSpaceError = 16 }, broken);
                Frame(t2, broken, 0, 1000, 0);
                Frame(t2, broken, 0, 1000, 0);
                Assert.Equal("A B C", Frame(t2, broken, 0, 1000, 0), "a root that fails to load: its children stand in");
                Assert.True(broken.Reports.Any(r => r.Contains("tileset_proxies/R.glb")), "reported by file");
                t2.Dispose();
            });

            t.Check("proxies: tiles.json entries with a missing child or tile are left out, with their parents", () =>
            {
                string json = @"{""format"": ""vworld-lod-tile-index"", ""version"": ""1.1"", ""tiles"": [
 {""name"": ""15_1_1"", ""center"": {""lon"": 1, ""lat"": 2, ""elev"": 0}, ""manifest"": ""15_1_1/lod_manifest.json"", ""globe"": {""earth_radius_m"": 6378137, ""unity_radius"": 6378137}}],
 ""proxies"": [" + Proxy("14_0_0", "[\"15_1_1\", \"15_1_2\"]", "[]") + "," + Proxy("15_1_1", "[]", "[\"15_1_1\"]") + "," + Proxy("15_1_2", "[]", "[\"15_1_2\"]")
                    + "," + Proxy("13_0_0", "[\"14_0_0\"]", "[]") + "," + Proxy("15_1_3", "[]", "[\"15_1_1\"]").Replace("tileset_proxies/15_1_3.glb", "../x.glb") + "]}";
                var problems = new List<string>();
                ProxyEntry[] proxies;
                TileIndexReader.Read(json, "x/tiles.json", j => PlainJsonManifestParser.ParseAs<TileIndex>(j, "x/tiles.json"), problems, out proxies);
                Assert.Equal("15_1_1", string.Join(" ", proxies.Select(p => p.name)), "usable proxies");
                Assert.Equal(4, problems.Count, "problems: " + string.Join(" | ", problems));
                Assert.True(problems.Any(p => p.Contains("proxies[2] (15_1_2)") && p.Contains("15_1_2 is not in the index")), "missing tile named");
                Assert.True(problems.Any(p => p.Contains("proxies[3] (13_0_0)")), "the grandparent too");
                Assert.True(problems.Any(p => p.Contains("leaves the index's folder")), "a file escaping the export");
            });
        }

        static string Proxy(string name, string children, string tiles)
        {
            return @"{""name"": """ + name + @""", ""center"": {""lon"": 1, ""lat"": 2, ""elev"": 0}, ""file"": ""tileset_proxies/" + name + @".glb"",
 ""placement"": {""position"": [0, 0, 0], ""rotation"": [0, 0, 0, 1], ""scale"": 1}, ""radius_m"": 10, ""geometric_error"": 1,
 ""children"": " + children + @", ""tiles"": " + tiles + @", ""globe"": {""earth_radius_m"": 6378137, ""unity_radius"": 6378137}}";
        }

        static List<object> L(object o) { return (List<object>)o; }
        static Dictionary<string, object> D(object o) { return (Dictionary<string, object>)o; }

        /// <summary>
        /// path: {"index": tiles.json of a real export with a tileset, "origin": {lon, lat, elev},
        /// "load": building radius, "height": px, "fov": degrees, "steps": [{"camera": [x, y, z],
        /// "visible": [proxy names], "buildings": [tile names]}]}: at each camera position, once loads
        /// have settled, the proxies shown and the tiles showing buildings.
        /// </summary>
        public static void Run(TestRunner t, string path)
        {
            var spec = D(PlainJson.Parse(File.ReadAllText(path)));
            string indexPath = (string)spec["index"];
            string folder = Path.GetDirectoryName(indexPath);
            var o = D(spec["origin"]);
            var origin = new GeoOrigin((double)o["lon"], (double)o["lat"], (double)o["elev"]);
            double load = (double)spec["load"], height = (double)spec["height"], fov = (double)spec["fov"];
            t.Check("proxies: a real export's tiles.json streams the proxies beyond the building radius", () =>
            {
                var problems = new List<string>();
                ProxyEntry[] proxies;
                TileIndexEntry[] tiles = TileIndexReader.Read(File.ReadAllText(indexPath), indexPath, j => PlainJsonManifestParser.ParseAs<TileIndex>(j, indexPath), problems, out proxies);
                Assert.Equal(0, problems.Count, "problems: " + string.Join(" | ", problems));
                Assert.True(proxies.Length >= 3, "proxies: " + proxies.Length);
                foreach (ProxyEntry p in proxies)
                {
                    // The index's globe placement (exporter.placement.tile_placement) is where a
                    // tile root at the proxy's centre goes (VWorldLodTilePlacement without a georeference).
                    Placement given = p.ScenePose(null);
                    double[] at = Placement.GlobePosition(p.center.lon, p.center.lat, 0, p.globe.earth_radius_m, p.globe.unity_radius);
                    double[] q = Placement.EastUpNorthRotation(p.center.lon, p.center.lat);
                    Assert.Near(0, Math.Sqrt(Math.Pow(given.px - at[0], 2) + Math.Pow(given.py - at[1], 2) + Math.Pow(given.pz - at[2], 2)), 0.01, p.name + " position (m)");
                    Assert.Near(1, Math.Abs(given.qx * q[0] + given.qy * q[1] + given.qz * q[2] + given.qw * q[3]), 1e-9, p.name + " rotation");
                    Placement framed = p.ScenePose(origin);
                    double[] scene = p.ScenePosition(origin);
                    Assert.Near(0, Math.Abs(framed.px - scene[0]) + Math.Abs(framed.py - scene[1]) + Math.Abs(framed.pz - scene[2]), 1e-9, p.name + " georeferenced pose at its position");
                }
                // Whole proxy textures: what shows follows 3D Tiles' screen-space-error rule alone,
                // as the steps expect (since the exporter's 0.6.0 a parent's atlas can hold its
                // children's at 1:1, and the memory rule then refines into them earlier: tested
                // on its own above).
                var settings = new StreamingSettings { LoadRadius = load, UnloadRadius = load * 1.2, Horizontal = true, ProxyTextureScreenSpaceError = 0 };
                var tileBackend = new FakeBackend(folder);
                var tileStreamer = new TileStreamer(tiles, e => e.ScenePosition(origin), settings, tileBackend);
                var backend = new FakeProxyBackend(folder);
                var streamer = new ProxyStreamer(proxies, p => p.ScenePosition(origin), settings, backend);
                streamer.TileShown = tileStreamer.Shows;
                int frame = 0, stepIndex = 0;
                foreach (object stepObject in L(spec["steps"]))
                {
                    var step = D(stepObject);
                    double[] c = L(step["camera"]).Select(v => (double)v).ToArray();
                    for (int settle = 0; settle < 30; settle++, frame++)
                    {
                        tileBackend.Frame = frame;
                        tileBackend.CompleteStartedBefore(frame);
                        tileStreamer.Update(c[0], c[1], c[2]);
                        streamer.Update(c[0], c[1], c[2], height, fov);
                        foreach (string v in streamer.Visible())
                            foreach (string tile in proxies.First(p => p.name == v).tiles)
                                Assert.True(!tileStreamer.Shows(tile), "proxy " + v + " drawn over the buildings of " + tile + " at step " + stepIndex);
                        backend.CompleteAll();
                    }
                    string want = string.Join(" ", L(step["visible"]).Cast<string>().OrderBy(n => n));
                    Assert.Equal(want, string.Join(" ", streamer.Visible().OrderBy(n => n)), "proxies shown at step " + stepIndex);
                    Assert.Equal(want, backend.Drawn(), "proxies drawn at step " + stepIndex);
                    string buildings = string.Join(" ", L(step["buildings"]).Cast<string>().OrderBy(n => n));
                    Assert.Equal(buildings, string.Join(" ", tiles.Where(x => tileStreamer.Shows(x.name)).Select(x => x.name).OrderBy(n => n)), "tiles with buildings at step " + stepIndex);
                    stepIndex++;
                }
                Assert.Equal(0, backend.Reports.Count, "reports: " + string.Join(" | ", backend.Reports));
                streamer.Dispose();
                tileStreamer.Dispose();
                Assert.True(backend.Handles.All(h => h.Released), "all proxies released");
            });
        }
    }
}
