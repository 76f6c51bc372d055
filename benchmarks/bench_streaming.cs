// The driver of bench_streaming.py: the package's plain-C# streamers (TileStreamer +
// ProxyStreamer, Runtime/Plan) along a scripted camera path, with fake backends whose loads
// complete on the next frame and which account texture bytes from the export (the table
// bench_streaming.py computes from the manifests and proxy files). Compiled twice: against this
// checkout's Runtime/Plan with -define:NEW, and against a baseline commit's (the streamer before
// issue 35), so it names only what both have.
//
//   mono bench_streaming.exe SPEC.json    prints one line per frame after the warm-up:
//   FRAME <n> <resident texture bytes> <level bytes> <proxy bytes> <holes> <loads started>
//   HOLE <n> <tile> <no-manifest | buildings-missing>   (one per tile in a hole)
//
// A hole: a tile of the export showing neither a visible proxy over it nor its buildings, where
// "its buildings" means every building its LODGroup would draw at the camera's distance
// (screen-relative height at least the last transition) has a level shown.
using System;
using System.Collections.Generic;
using System.Globalization;
using System.IO;
using System.Threading;
using System.Threading.Tasks;
using VWorldLod;

public static class BenchStreaming
{
    sealed class Handle
    {
        public long Bytes;
        public bool Released, Visible;
        public string Proxy;
    }

    sealed class Pending
    {
        public int Frame;
        public Action Complete;
    }

    static int frame;
    static long levelBytes, proxyBytes, loadsStarted;
    static readonly List<Pending> pending = new List<Pending>();

    static void Later(Action complete)
    {
        pending.Add(new Pending { Frame = frame, Complete = complete });
        loadsStarted++;
    }

    static void CompleteStartedBefore(int now)
    {
        var due = pending.FindAll(p => p.Frame < now);
        pending.RemoveAll(p => p.Frame < now);
        foreach (Pending p in due) p.Complete();
    }

    sealed class Levels : IStreamingBackend
    {
        public Dictionary<string, object> Bytes;
        public string Folder;
        public readonly Dictionary<string, TilePlan> Plans = new Dictionary<string, TilePlan>();
        public readonly Dictionary<BuildingPlan, int> Shown = new Dictionary<BuildingPlan, int>();

        public Task<TilePlan> LoadTile(TileIndexEntry tile, CancellationToken cancellation)
        {
            var done = new TaskCompletionSource<TilePlan>();
            Later(() =>
            {
                TilePlan plan = LodPlanner.Load(Path.Combine(Folder, tile.manifest), new PlainJsonManifestParser(), p => true);
                Plans[tile.name] = plan;
                done.SetResult(plan);
            });
            return done.Task;
        }

        public Task<object> LoadLevel(TilePlan tile, BuildingPlan building, int level, CancellationToken cancellation)
        {
            var done = new TaskCompletionSource<object>();
            Later(() =>
            {
                var h = new Handle { Bytes = (long)(double)Bytes[tile.TileName + "/" + building.Id + "/" + level] };
                levelBytes += h.Bytes;
                done.SetResult(h);
            });
            return done.Task;
        }

        public void ShowLevels(TilePlan tile, BuildingPlan building, int[] levels, object[] loaded) { Shown[building] = levels.Length; }

        public void ReleaseLevel(object loaded)
        {
            var h = (Handle)loaded;
            if (h.Released) throw new InvalidOperationException("released twice");
            h.Released = true;
            levelBytes -= h.Bytes;
        }

        public void UnloadTile(TilePlan tile)
        {
            Plans.Remove(tile.TileName);
            foreach (BuildingPlan b in tile.Buildings) Shown.Remove(b);
        }

        public void Report(string message) { Console.Error.WriteLine(message); }
    }

    sealed class Proxies : IProxyBackend
    {
        public Dictionary<string, object> Bytes;
        public readonly List<Handle> Loaded = new List<Handle>();

#if NEW
        public Dictionary<string, object> Images; // per proxy: its distinct images' [width, height]
        public double BytesPerPixel;

        // Its images without their mipmapLimit finest mip levels (at least one kept), as the budget counts them.
        long LimitedBytes(ProxyEntry proxy, int mipmapLimit)
        {
            double bytes = 0;
            foreach (object image in (List<object>)Images[proxy.name])
            {
                var size = (List<object>)image;
                int w = (int)Num(size[0]), h = (int)Num(size[1]);
                for (int k = 0; k < mipmapLimit && Math.Max(w, h) > 1; k++) { w = Math.Max(1, w / 2); h = Math.Max(1, h / 2); }
                bytes += Math.Ceiling((double)w * h * BytesPerPixel * 4.0 / 3.0);
            }
            return (long)bytes;
        }

        public Task<object> LoadProxy(ProxyEntry proxy, int mipmapLimit, CancellationToken cancellation)
        {
            var done = new TaskCompletionSource<object>();
            Later(() =>
            {
                var h = new Handle { Bytes = LimitedBytes(proxy, mipmapLimit), Proxy = proxy.name };
                proxyBytes += h.Bytes;
                Loaded.Add(h);
                done.SetResult(h);
            });
            return done.Task;
        }
#else
        public Task<object> LoadProxy(ProxyEntry proxy, CancellationToken cancellation)
        {
            var done = new TaskCompletionSource<object>();
            Later(() =>
            {
                var h = new Handle { Bytes = (long)(double)Bytes[proxy.name], Proxy = proxy.name };
                proxyBytes += h.Bytes;
                Loaded.Add(h);
                done.SetResult(h);
            });
            return done.Task;
        }
#endif

        public void ShowProxy(object loaded, bool visible) { ((Handle)loaded).Visible = visible; }

#if NEW
        public long TextureBytes(object loaded) { return ((Handle)loaded).Bytes; }
#endif

        public void ReleaseProxy(object loaded)
        {
            var h = (Handle)loaded;
            if (h.Released) throw new InvalidOperationException("released twice");
            h.Released = true;
            proxyBytes -= h.Bytes;
            Loaded.Remove(h);
        }

        public void Report(string message) { Console.Error.WriteLine(message); }
    }

    static double Num(object o) { return (double)o; }

    public static int Main(string[] args)
    {
        Thread.CurrentThread.CurrentCulture = CultureInfo.InvariantCulture;
        var spec = (Dictionary<string, object>)PlainJson.Parse(File.ReadAllText(args[0]));
        string indexPath = (string)spec["index"];
        var o = (Dictionary<string, object>)spec["origin"];
        var origin = new GeoOrigin(Num(o["lon"]), Num(o["lat"]), 0);
        var s = (Dictionary<string, object>)spec["settings"];
        var settings = new StreamingSettings
        {
            LoadRadius = Num(s["load"]), UnloadRadius = Num(s["unload"]), MaxConcurrentLoads = (int)Num(s["max"]), Horizontal = true,
#if NEW
            TextureBudgetBytes = Num(s["budget"]), TextureBytesPerPixel = Num(s["bytes_per_pixel"]),
#endif
        };
        double height = Num(spec["screen_height"]), fov = Num(spec["fov"]);
        int warmup = (int)Num(spec["warmup"]);
        var sizes = (Dictionary<string, object>)spec["building_size"];
        var camera = ((List<object>)spec["camera"]).ConvertAll(p => ((List<object>)p).ConvertAll(Num).ToArray());

        var problems = new List<string>();
        ProxyEntry[] proxyEntries;
        TileIndexEntry[] tiles = TileIndexReader.Read(File.ReadAllText(indexPath), indexPath, json => PlainJsonManifestParser.ParseAs<TileIndex>(json, indexPath), problems, out proxyEntries);
        var levels = new Levels { Bytes = (Dictionary<string, object>)spec["level_bytes"], Folder = Path.GetDirectoryName(indexPath) };
        var proxies = new Proxies { Bytes = (Dictionary<string, object>)spec["proxy_bytes"] };
#if NEW
        proxies.Images = (Dictionary<string, object>)spec["proxy_images"];
        proxies.BytesPerPixel = Num(s["bytes_per_pixel"]);
        if (spec.ContainsKey("proxy_texture_sse")) settings.ProxyTextureScreenSpaceError = Num(spec["proxy_texture_sse"]);
#endif
        var tileStreamer = new TileStreamer(tiles, e => e.ScenePosition(origin), settings, levels);
#if NEW
        var proxyStreamer = new ProxyStreamer(proxyEntries, p => p.ScenePosition(origin), settings, proxies, tileStreamer.Budget);
#else
        var proxyStreamer = new ProxyStreamer(proxyEntries, p => p.ScenePosition(origin), settings, proxies);
#endif
        proxyStreamer.TileShown = tileStreamer.Shows;
        int proxyLoads = 0, finerLoads = 0;
        proxyStreamer.OnEvent = e => { if (e.StartsWith("load finer ")) finerLoads++; else if (e.StartsWith("load ")) proxyLoads++; };
#if NEW
        proxyStreamer.TileLoading = tileStreamer.Loading;
        tileStreamer.ProxyShown = proxyStreamer.Covers;
#endif

        // The building tiles under each proxy (itself and its descendants).
        var byName = new Dictionary<string, ProxyEntry>();
        foreach (ProxyEntry p in proxyEntries) byName[p.name] = p;
        var covers = new Dictionary<string, HashSet<string>>();
        foreach (ProxyEntry p in proxyEntries) covers[p.name] = Covered(p, byName);
        var centres = new Dictionary<string, double[]>();
        foreach (TileIndexEntry t in tiles) centres[t.name] = t.ScenePosition(origin);

        for (int step = -warmup; step < camera.Count; step++)
        {
            double[] c = camera[Math.Max(step, 0)];
            frame++;
            CompleteStartedBefore(frame);
#if NEW
            tileStreamer.Update(c[0], c[1], c[2], height, fov, 1);
#else
            tileStreamer.Update(c[0], c[1], c[2]);
#endif
            proxyStreamer.Update(c[0], c[1], c[2], height, fov);
            if (step < 0) continue;
            var underVisible = new HashSet<string>();
            foreach (Handle h in proxies.Loaded) if (h.Visible) underVisible.UnionWith(covers[h.Proxy]);
            int holes = 0;
            foreach (TileIndexEntry t in tiles)
            {
                if (underVisible.Contains(t.name)) continue;
                TilePlan plan;
                bool shows = levels.Plans.TryGetValue(t.name, out plan);
                if (shows)
                    foreach (BuildingPlan b in plan.Buildings)
                    {
                        double[] at = centres[t.name];
                        // Size and bounds centre (East, Up, North offsets, metres) from the manifest.
                        var box = (List<object>)sizes[t.name + "/" + b.Id];
                        double dx = at[0] + b.Relative.px + Num(box[1]) - c[0], dy = at[1] + b.Relative.py + Num(box[2]) - c[1], dz = at[2] + b.Relative.pz + Num(box[3]) - c[2];
                        double d = Math.Max(Math.Sqrt(dx * dx + dy * dy + dz * dz), 1e-6);
                        double rel = Num(box[0]) / (2 * d * Math.Tan(fov * Math.PI / 360));
                        if (rel < b.Levels[b.Levels.Length - 1].ScreenRelativeHeight) continue; // culled by its LODGroup
                        int n;
                        if (!levels.Shown.TryGetValue(b, out n) || n == 0) { shows = false; break; }
                    }
                if (shows) continue;
                holes++;
                Console.WriteLine("HOLE " + step + " " + t.name + (levels.Plans.ContainsKey(t.name) ? " buildings-missing" : " no-manifest"));
            }
            if (Environment.GetEnvironmentVariable("BENCH_PROXIES") != null)
                Console.WriteLine("PROXIES " + step + " " + string.Join(" ", proxies.Loaded.ConvertAll(h => h.Proxy + ":" + (h.Bytes >> 10) + (h.Visible ? "v" : "")).ToArray()));
            Console.WriteLine("FRAME " + step + " " + (levelBytes + proxyBytes) + " " + levelBytes + " " + proxyBytes + " " + holes + " " + loadsStarted);
        }
        Console.WriteLine("PROXY_LOADS " + proxyLoads + " " + finerLoads);
        tileStreamer.Dispose();
        proxyStreamer.Dispose();
        return 0;
    }

    static HashSet<string> Covered(ProxyEntry p, Dictionary<string, ProxyEntry> byName)
    {
        var all = new HashSet<string>(p.tiles ?? new string[0]);
        foreach (string c in p.children ?? new string[0])
        {
            ProxyEntry child;
            if (byName.TryGetValue(c, out child)) all.UnionWith(Covered(child, byName));
        }
        return all;
    }
}
