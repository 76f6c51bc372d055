// TileStreamer's one level per building (LevelChoice, TextureBudget), cancellation freeing its
// slot, and Update allocating nothing in a steady state: over the PlanTests sample manifest
// (building B1: levels of 256, 128 and 64 texels, 10 m East, 20 m South of the tile centre, no
// bounds: LODGroup.size 30 m; heights 0.5, 0.17, 0.02) with a backend whose loads complete at once
// or never.
using System;
using System.Collections.Generic;
using System.Linq;
using System.Threading;
using System.Threading.Tasks;

namespace VWorldLod.Tests
{
    public class PlanBackend : IStreamingBackend
    {
        public class Handle { public string What; public bool Released; }

        readonly Func<TilePlan> plan;
        public bool Hang; // level loads never complete (a stalled download) until Finish
        public readonly List<TaskCompletionSource<object>> Hung = new List<TaskCompletionSource<object>>();
        public readonly List<Handle> Handles = new List<Handle>();
        public readonly List<string> Reports = new List<string>();
        public readonly List<CancellationToken> Tokens = new List<CancellationToken>();

        public PlanBackend(Func<TilePlan> plan) { this.plan = plan; }

        public Task<TilePlan> LoadTile(TileIndexEntry tile, CancellationToken c) { return Task.FromResult(plan()); }

        public Task<object> LoadLevel(TilePlan tile, BuildingPlan b, int level, CancellationToken c)
        {
            Tokens.Add(c);
            var h = new Handle { What = b.Id + " " + level };
            if (!Hang)
            {
                Handles.Add(h);
                return Task.FromResult<object>(h);
            }
            var done = new TaskCompletionSource<object>();
            Hung.Add(done);
            return done.Task;
        }

        /// <summary>The stalled loads finally answer, each with a handle.</summary>
        public void Finish()
        {
            foreach (var done in Hung)
            {
                var h = new Handle { What = "late" };
                Handles.Add(h);
                done.SetResult(h);
            }
            Hung.Clear();
        }

        public void ShowLevels(TilePlan tile, BuildingPlan b, int[] levels, object[] loaded) { }
        public void ReleaseLevel(object loaded) { var h = (Handle)loaded; if (h.Released) throw new TestFailure("released twice"); h.Released = true; }
        public void UnloadTile(TilePlan tile) { }
        public void Report(string message) { Reports.Add(message); }
    }

    public static class LevelChoiceTests
    {
        static TileIndexEntry[] OneTile()
        {
            return new[] { new TileIndexEntry { name = "15_279418_116113", manifest = "15_279418_116113/lod_manifest.json", globe = new GlobeInfo { earth_radius_m = 6378137, unity_radius = 6378137 } } };
        }

        static TilePlan Sample(Action<TileManifest> change = null)
        {
            TileManifest m = PlanTests.Parse(PlanTests.Sample);
            if (change != null) change(m);
            return LodPlanner.Plan(m, PlanTests.ManifestPath, p => true);
        }

        // Camera D metres North of B1 (10, 0.5, -20 in the tile's frame at the scene origin).
        static void At(TileStreamer s, double d, int frames = 3)
        {
            for (int i = 0; i < frames; i++) s.Update(10, 0.5, -20 + d, 1080, 60, 1);
        }

        static string B1(TileStreamer s) { return string.Join(",", s.ResidentLevels("15_279418_116113", "B1")); }

        public static void Run(TestRunner t)
        {
            // h = 30 / (2 D tan 30deg) = 25.98 / D: LOD0 closer than 52 m, LOD1 to 152 m, LOD2 to 1299 m, then culled.
            t.Check("levels: each building holds the level its LODGroup shows at its distance, and no other", () =>
            {
                var backend = new PlanBackend(() => Sample());
                var s = new TileStreamer(OneTile(), e => new double[3], new StreamingSettings { LoadRadius = 5000, UnloadRadius = 6000 }, backend);
                At(s, 500);
                Assert.Equal("2", B1(s), "LOD2 at 500 m");
                Assert.Equal(21846, s.Budget.Resident - ResidentOtherThanB1(s), "64 x 64 RGBA32 + mips");
                At(s, 5000); // beyond 1.1 x its culling distance: nothing
                Assert.Equal("", B1(s), "culled at 5 km");
                At(s, 1350); // culled by the LODGroup from 1299 m, loaded from 10 % beyond
                Assert.Equal("2", B1(s), "coarsest level loaded just before it is drawn");
                var events = new List<string>();
                s.OnEvent = events.Add;
                At(s, 100, 1);
                Assert.Equal("2", B1(s), "LOD2 holds while LOD1 loads");
                Assert.True(events.Contains("request 15_279418_116113 B1 1"), "LOD1 requested: " + string.Join(", ", events));
                At(s, 100, 1);
                Assert.Equal("1", B1(s), "LOD1 arrived, LOD2 released");
                At(s, 40);
                Assert.Equal("0", B1(s), "LOD0 at 40 m");
                Assert.True(backend.Handles.Where(h => h.Released).Count() >= 3, "released levels went back to the backend");
                s.Dispose();
                Assert.True(backend.Handles.All(h => h.Released), "Dispose releases all");
                Assert.Equal(0, s.Budget.Resident, "no bytes left");
            });

            t.Check("levels: the next finer level is loaded ahead while the camera approaches, not while it leaves", () =>
            {
                var backend = new PlanBackend(() => Sample());
                var s = new TileStreamer(OneTile(), e => new double[3], new StreamingSettings { LoadRadius = 5000, UnloadRadius = 6000 }, backend);
                At(s, 500);
                At(s, 170); // h 0.153: LOD2; x 1.25 (PrefetchFactor) = 0.19 reaches LOD1's 0.17
                Assert.Equal("1,2", B1(s), "approaching: LOD1 ahead");
                At(s, 178); // moving away: no prefetch; LOD1 is needed from 152 m, kept to 152 x 1.1 = 168 m
                Assert.Equal("2", B1(s), "leaving: LOD1 released");
                At(s, 175);
                Assert.Equal("1,2", B1(s), "approaching again: LOD1 ahead again");
                s.Dispose();
            });

            t.Check("levels: a level whose error_m would show more than the limit is replaced by the finer one", () =>
            {
                var backend = new PlanBackend(() => Sample(m =>
                {
                    m.buildings[0].lods[1].error_m = 0.01;
                    m.buildings[0].lods[2].error_m = 5; // 5 m at 500 m: 9.4 px on 1080 px, 60 degrees
                }));
                var s = new TileStreamer(OneTile(), e => new double[3], new StreamingSettings { LoadRadius = 5000, UnloadRadius = 6000, LevelMaximumScreenSpaceError = 2 }, backend);
                At(s, 500);
                Assert.Equal("1", B1(s), "LOD1 where LOD2's texture error shows");
                At(s, 1200); // 5 m at 1200 m: 3.9 px, still above 2
                Assert.Equal("1", B1(s), "still LOD1");
                s.Dispose();
                var loose = new TileStreamer(OneTile(), e => new double[3], new StreamingSettings { LoadRadius = 5000, UnloadRadius = 6000 }, new PlanBackend(() => Sample(m => m.buildings[0].lods[2].error_m = 5)));
                At(loose, 500);
                Assert.Equal("2", B1(loose), "with the default 16 px limit (error_m is tileset.json's geometricError) LOD2 is fine");
                loose.Dispose();
            });

            t.Check("levels: per-level error is error_m, else hausdorff_rel x LOD0's bounding-box diagonal, else unknown", () =>
            {
                TileManifest m = PlanTests.Parse(PlanTests.Sample);
                LodEntry[] lods = m.buildings[0].lods;
                lods[0].gltf_bounds = new GltfBounds { low = new double[] { -3, 0, -4 }, high = new double[] { 3, 12, 4 } }; // diagonal sqrt(36 + 144 + 64)
                lods[1].quality = new LodQuality { hausdorff_rel = 0.01 };
                lods[2].quality = new LodQuality { hausdorff_rel = 0.02 };
                double[] e = LodPlanner.LevelErrors(lods);
                Assert.Near(0, e[0], 0, "LOD0");
                Assert.Near(0.01 * Math.Sqrt(244), e[1], 1e-12, "LOD1 from hausdorff_rel");
                Assert.Near(0.02 * Math.Sqrt(244), e[2], 1e-12, "LOD2 from hausdorff_rel");
                lods[2].error_m = 0.7;
                e = LodPlanner.LevelErrors(lods);
                Assert.Near(0.7, e[2], 0, "error_m when present");
                Assert.Near(0, e[1], 0, "error_m present on the building: its levels' own (0 = exact)");
                TilePlan plan = LodPlanner.Plan(m, PlanTests.ManifestPath, p => true);
                Assert.Near(12, plan.Buildings[0].Size, 0, "LODGroup.size: the largest side");
                Assert.True(double.IsNaN(LodPlanner.LevelErrors(PlanTests.Parse(PlanTests.Sample).buildings[0].lods)[1]), "no quality, no bounds: unknown");
            });

            t.Check("levels: the texture budget counts texels x bytes per texel x 4/3 and is said once when passed", () =>
            {
                var backend = new PlanBackend(() => Sample());
                var settings = new StreamingSettings { LoadRadius = 5000, UnloadRadius = 6000, TextureBudgetBytes = 50000, TextureBytesPerPixel = 1 };
                var s = new TileStreamer(OneTile(), e => new double[3], settings, backend);
                Assert.Equal(87382, s.Budget.Bytes(256, 256), "256 x 256 at 1 byte (BC7 / ASTC 4x4) with mips");
                At(s, 40);
                Assert.Equal("0", B1(s), "LOD0 still loads over the budget (the view needs it)");
                At(s, 40);
                Assert.Equal(1, backend.Reports.Count(r => r.Contains("texture budget")), "said once: " + string.Join(" | ", backend.Reports));
                s.Dispose();
            });

            t.Check("cancelling: an unloaded tile's stalled loads free their slots at once and are released when they answer", () =>
            {
                var backend = new PlanBackend(() => Sample()) { Hang = true };
                var s = new TileStreamer(OneTile(), e => new double[3], new StreamingSettings { LoadRadius = 5000, UnloadRadius = 6000, MaxConcurrentLoads = 2 }, backend);
                var events = new List<string>();
                s.OnEvent = events.Add;
                At(s, 40);
                Assert.Equal(2, s.InFlight, "both slots taken by stalled level loads");
                At(s, 1e7, 1); // away: the tile unloads
                Assert.Equal(0, s.InFlight, "slots free at once");
                Assert.True(backend.Tokens.All(c => c.IsCancellationRequested), "their loads were told to stop");
                events.Clear();
                At(s, 40, 1); // back: new loads start in the same frame
                Assert.True(events.Contains("request 15_279418_116113"), "the manifest is requested again at once: " + string.Join(", ", events));
                backend.Hang = false;
                backend.Finish();
                At(s, 40);
                s.Dispose();
                Assert.True(backend.Handles.Where(h => h.What == "late").All(h => h.Released), "late answers released");
            });

            t.Check("leaving: a tile beyond the unload radius keeps its buildings until a proxy over it shows", () =>
            {
                var backend = new PlanBackend(() => Sample());
                var s = new TileStreamer(OneTile(), e => new double[3], new StreamingSettings { LoadRadius = 1000, UnloadRadius = 1200 }, backend);
                bool proxyShown = false;
                s.ProxyShown = name => proxyShown;
                At(s, 500);
                Assert.True(s.Shows("15_279418_116113"), "shows its buildings");
                At(s, 1300); // beyond the unload radius, no proxy yet
                Assert.Equal("2", B1(s), "B1 still holds its level");
                Assert.True(!s.Shows("15_279418_116113") && !s.Loading("15_279418_116113"), "says it does not show, so its proxy is brought");
                proxyShown = true;
                At(s, 1300, 1);
                Assert.Equal(0, s.LoadedTiles().Count, "unloaded once the proxy shows");
                Assert.True(backend.Handles.All(h => h.Released), "its levels released");
                proxyShown = false;
                At(s, 500);
                At(s, 1500, 1); // beyond 2 x 1200 - 1000 = 1400: unloaded whatever the proxy
                Assert.Equal(0, s.LoadedTiles().Count, "unloaded far enough out");
                s.Dispose();
            });

            t.Check("levels: Update allocates nothing once streaming has settled", () =>
            {
                var backend = new PlanBackend(() => Sample());
                var settings = new StreamingSettings { LoadRadius = 5000, UnloadRadius = 6000 };
                var s = new TileStreamer(OneTile(), e => new double[3], settings, backend);
                var proxyBackend = new FakeProxyBackend();
                var proxies = new ProxyStreamer(ProxyTests.Tree(), p => ProxyTests.At[p.name], settings, proxyBackend, s.Budget);
                proxies.TileShown = s.Shows;
                proxies.TileLoading = s.Loading;
                s.ProxyShown = proxies.Covers;
                for (int i = 0; i < 10; i++) { s.Update(10, 0.5, 480, 1080, 60, 1); proxies.Update(10, 0.5, 480, 1080, 60); proxyBackend.CompleteAll(); }
                Assert.True(proxies.Visible().Count > 0 && s.Shows("15_279418_116113"), "buildings and proxies shown");
                long tiles = 0, proxyBytes = 0;
                for (int i = 0; i < 100; i++)
                {
                    double z = 480 + i * 0.01; // moving a little, nothing changes
                    long before = GC.GetAllocatedBytesForCurrentThread();
                    s.Update(10, 0.5, z, 1080, 60, 1);
                    long between = GC.GetAllocatedBytesForCurrentThread();
                    proxies.Update(10, 0.5, z, 1080, 60);
                    tiles += between - before;
                    proxyBytes += GC.GetAllocatedBytesForCurrentThread() - between;
                }
                Assert.Equal(0L, tiles, "bytes TileStreamer.Update allocated in 100 frames");
                Assert.Equal(0L, proxyBytes, "bytes ProxyStreamer.Update allocated in 100 frames");
                s.Dispose();
            });
        }

        static long ResidentOtherThanB1(TileStreamer s)
        {
            // B/2 is untextured: 0 bytes.
            return 0;
        }
    }
}
