// Shows the tileset's HLOD proxies (tiles.json "proxies") beyond the building radius, coarse to
// fine, the way 3D Tiles clients select tiles. Plain C# (no Unity type), driven by Update(camera,
// screen) once a frame after TileStreamer; all I/O goes through an IProxyBackend.
//
// Per Update:
//   1. finish: completed loads are taken in (released when no longer wanted);
//   2. want: from each root down, a proxy is wanted when none of its building tiles shows its
//      buildings (TileShown) and its screen-space error is at most MaximumScreenSpaceError (and
//      its file did not fail to load, and its children would not hold less texture memory:
//      ChildrenLighter), or it cannot be refined (no child proxies, or buildings of its own);
//      otherwise its children are visited. Screen-space error (px) = geometric_error * screenHeight / (d * 2 tan(fov / 2)),
//      d in metres from the camera to the proxy's bounding sphere (3D Tiles' rule);
//   3. show: a wanted, loaded proxy shows; until it is loaded, its loaded descendants nearest to
//      it show instead; a refined proxy whose region is not complete yet (a wanted child not
//      loaded) stays shown itself when loaded, also over a tile of it that already shows its
//      buildings: a view never gets holes while finer proxies arrive (the price: that place drawn
//      twice meanwhile). A building tile counts as shown (TileShown, TileStreamer.Shows) only once
//      every building of it the view needs shows a level, so a proxy stays until then;
//   4. proxies neither wanted nor shown are released (their texture bytes are counted in the
//      TextureBudget shared with TileStreamer); loads of proxies no longer wanted are cancelled,
//      freeing their slot at once. The way back needs no cache of covered proxies: a tile leaving
//      the radius keeps its buildings until a proxy over it shows (Covers, TileStreamer.ProxyShown)
//      -- its levels are a fraction of a proxy's atlas (up to 2048 texels a side: 21 MiB in RGBA32);
//   5. start loads of wanted proxies, coarsest level first, nearer first, while fewer than
//      MaxConcurrentLoads are in flight; a proxy whose tiles are all loading their buildings
//      (TileLoading) is not loaded when a loaded ancestor stands in meanwhile (its buildings
//      will replace it soon: no 2048-texel atlas downloaded for a few frames).
// Texture memory: a proxy loads without the finest mip levels of its textures that its distance
// does not need (MipmapLimit: its texel, bounded by geometric_error, doubled per level left out,
// looks at most ProxyTextureScreenSpaceError px), and loads again finer (after every missing proxy)
// when the camera comes closer, the coarser copy shown until the finer one has arrived.
// Update allocates nothing in a steady state (its buffers are fields).
// Positions are scene positions of the proxies' frame origins (Unity units), from the caller's
// function (ProxyEntry.ScenePosition), recomputed by Reposition().
using System;
using System.Collections.Generic;
using System.Threading;
using System.Threading.Tasks;

namespace VWorldLod
{
    public sealed class ProxyStreamer : IDisposable
    {
        sealed class Node
        {
            public ProxyEntry Entry;
            public int Index;
            public int[] Children;
            public int Parent = -1;
            public object Handle; // loaded
            public Job Loading;
            public long Bytes; // texture bytes of the loaded proxy (IProxyBackend.TextureBytes)
            public int Limit; // mip levels left out of the loaded proxy's textures
            public int NeedLimit; // how many its distance allows now
            public bool Visible, Wanted, Failed, FinerFailed, Covered, RefinedLighter; // Covered: a tile below it shows its buildings
            public int[] Tiles; // indices (into tileNames) of the building tiles under it, its descendants' included
            public double Sse, Distance; // Distance: metres to its bounding sphere
        }

        sealed class Job
        {
            public Node Node;
            public int Limit; // mipmapLimit asked of the backend
            public Task<object> Task;
            public CancellationTokenSource Cancel = new CancellationTokenSource();
            public bool Cancelled;
        }

        readonly Node[] nodes;
        readonly List<int> roots = new List<int>();
        readonly Func<ProxyEntry, double[]> position;
        readonly StreamingSettings settings;
        readonly IProxyBackend backend;
        readonly List<Job> inFlight = new List<Job>();
        readonly List<Job> draining = new List<Job>(); // cancelled, not finished yet
        readonly List<Node> show = new List<Node>();
        readonly List<Node> waiting = new List<Node>();
        readonly bool[] visibleNow;
        readonly Dictionary<string, int> tileIndex = new Dictionary<string, int>();
        readonly List<string> tileNames = new List<string>();
        readonly bool[] drawnOver; // per building tile: a visible proxy is over it
        readonly TextureBudget budget;
        static readonly string[] None = new string[0];
        static readonly IComparer<Node> CoarsestNearestFirst = new LoadOrder();
        double[][] positions;
        bool disposed;

        /// <summary>Whether a building tile (tiles.json name) shows its buildings; a proxy over it is then hidden.</summary>
        public Func<string, bool> TileShown = name => false;

        /// <summary>Whether a building tile is loading its buildings (within the radius, not shown yet: TileStreamer.Loading).</summary>
        public Func<string, bool> TileLoading = name => false;

        /// <summary>Called with "load &lt;proxy&gt;", "show &lt;proxy&gt;", "hide &lt;proxy&gt;", "unload &lt;proxy&gt;".</summary>
        public Action<string> OnEvent;

        /// <summary>The most loads in flight at once so far.</summary>
        public int MaxInFlightSeen { get; private set; }

        public int InFlight { get { return inFlight.Count; } }

        /// <summary>Cancelled loads not finished yet (their results will be released).</summary>
        public int Draining { get { return draining.Count; } }

        public TextureBudget Budget { get { return budget; } }

        sealed class LoadOrder : IComparer<Node>
        {
            public int Compare(Node a, Node b)
            {
                return a.Entry.level != b.Entry.level ? a.Entry.level.CompareTo(b.Entry.level)
                    : a.Distance != b.Distance ? a.Distance.CompareTo(b.Distance) : a.Index.CompareTo(b.Index);
            }
        }

        /// <summary>
        /// proxies: usable entries (TileIndexReader.Read); children are named among them. budget:
        /// shared with the TileStreamer (its Budget); null makes one of settings.
        /// </summary>
        public ProxyStreamer(ProxyEntry[] proxies, Func<ProxyEntry, double[]> position, StreamingSettings settings, IProxyBackend backend, TextureBudget budget = null)
        {
            this.budget = budget ?? new TextureBudget(settings);
            string problem = settings.Problem();
            if (problem != null) throw new ArgumentException(problem);
            this.position = position;
            this.settings = settings;
            this.backend = backend;
            nodes = new Node[proxies.Length];
            visibleNow = new bool[proxies.Length];
            var byName = new Dictionary<string, int>();
            for (int i = 0; i < proxies.Length; i++)
            {
                nodes[i] = new Node { Entry = proxies[i], Index = i };
                byName[proxies[i].name] = i;
            }
            foreach (Node n in nodes)
            {
                var children = new List<int>();
                foreach (string c in n.Entry.children ?? new string[0])
                {
                    int k;
                    if (byName.TryGetValue(c, out k) && nodes[k].Parent < 0 && k != n.Index) { children.Add(k); nodes[k].Parent = n.Index; }
                }
                n.Children = children.ToArray();
            }
            for (int i = 0; i < nodes.Length; i++) if (nodes[i].Parent < 0) roots.Add(i);
            foreach (Node n in nodes)
            foreach (int r in roots) Gather(nodes[r]);
            drawnOver = new bool[tileNames.Count];
            Reposition();
        }

        /// <summary>Recomputes the proxies' scene positions (after the georeference origin moved).</summary>
        public void Reposition()
        {
            positions = new double[nodes.Length][];
            for (int i = 0; i < nodes.Length; i++) positions[i] = position(nodes[i].Entry);
        }

        /// <summary>
        /// Pixels: how large an error of errorMetres looks at distanceMetres on a screen
        /// screenHeight pixels tall with a vertical field of view of fovDegrees (3D Tiles' rule).
        /// </summary>
        public static double ScreenSpaceError(double errorMetres, double distanceMetres, double screenHeight, double fovDegrees)
        {
            double d = Math.Max(distanceMetres, 1e-6);
            return errorMetres * screenHeight / (d * 2 * Math.Tan(fovDegrees * Math.PI / 360.0));
        }

        /// <summary>The most mip levels a proxy's textures may leave out (2048 -> 16 texels a side).</summary>
        public const int MaxMipmapLimit = 7;

        /// <summary>
        /// How many of a proxy's finest texture mip levels may be left out: its atlas texel
        /// (tiles.json's texel_m, else its geometric error, which bounds it: tileset.json's error
        /// is the larger of the two) looks sse pixels large; each level left out doubles the
        /// texel, which must look at most maxPixels large. maxPixels 0: none left out.
        /// </summary>
        public static int MipmapLimit(double sse, double maxPixels)
        {
            if (!(maxPixels > 0) || !(sse > 0)) return 0;
            double levels = Math.Floor(Math.Log(maxPixels / sse, 2));
            return (int)Math.Max(0, Math.Min(MaxMipmapLimit, levels));
        }

        /// <summary>Mip levels left out of the loaded proxy's textures, or -1 when it is not loaded.</summary>
        public int LoadedMipmapLimit(string proxyName)
        {
            foreach (Node n in nodes) if (n.Entry.name == proxyName) return n.Handle == null ? -1 : n.Limit;
            return -1;
        }

        /// <summary>Names of the proxies wanted at the last Update, in index order.</summary>
        public List<string> Wanted() { return Names(n => n.Wanted); }

        /// <summary>Names of the proxies shown now, in index order.</summary>
        public List<string> Visible() { return Names(n => n.Visible); }

        /// <summary>Names of the loaded proxies, in index order.</summary>
        public List<string> Loaded() { return Names(n => n.Handle != null); }

        List<string> Names(Func<Node, bool> which)
        {
            var names = new List<string>();
            foreach (Node n in nodes) if (which(n)) names.Add(n.Entry.name);
            return names;
        }

        /// <summary>One frame: camera at scene position (x, y, z); screenHeight pixels, vertical field of view in degrees.</summary>
        public void Update(double x, double y, double z, double screenHeight, double fovDegrees)
        {
            if (disposed) return;
            Finish();
            foreach (Node n in nodes)
            {
                double[] p = positions[n.Index];
                double unitsPerMetre = n.Entry.globe.unity_radius / n.Entry.globe.earth_radius_m;
                double centre = Math.Sqrt((p[0] - x) * (p[0] - x) + (p[1] - y) * (p[1] - y) + (p[2] - z) * (p[2] - z)) / unitsPerMetre;
                n.Distance = Math.Max(centre - n.Entry.radius_m, 0);
                n.Sse = ScreenSpaceError(n.Entry.geometric_error, n.Distance, screenHeight, fovDegrees);
                // A proxy standing in while its tiles' buildings load (within the load radius) is
                // a placeholder for a few frames: textures as fine as it would need at the load radius.
                double seen = BuildingsComing(n) ? Math.Max(n.Distance, settings.LoadRadius / unitsPerMetre) : n.Distance;
                // The atlas's own texel when tiles.json states it; else the error, which bounds it.
                double texel = n.Entry.texel_m > 0 ? Math.Min(n.Entry.texel_m, n.Entry.geometric_error) : n.Entry.geometric_error;
                n.NeedLimit = MipmapLimit(ScreenSpaceError(texel, seen, screenHeight, fovDegrees), settings.ProxyTextureScreenSpaceError);
                n.Wanted = false;
            }
            foreach (int r in roots) Cover(nodes[r]);
            foreach (int r in roots) Want(nodes[r]);
            show.Clear();
            foreach (int r in roots) Show(nodes[r]);
            Array.Clear(visibleNow, 0, visibleNow.Length);
            foreach (Node n in show) visibleNow[n.Index] = true;
            Array.Clear(drawnOver, 0, drawnOver.Length);
            foreach (Node n in show) foreach (int t in n.Tiles) drawnOver[t] = true;
            foreach (Node n in nodes)
            {
                bool visible = visibleNow[n.Index];
                if (visible == n.Visible) continue;
                n.Visible = visible;
                object h = n.Handle;
                ShowProxy(h, visible);
                Event((visible ? "show " : "hide ") + n.Entry.name);
            }
            foreach (Node n in nodes)
            {
                if (n.Handle != null && !n.Wanted && !n.Visible) Release(n);
                if (n.Loading != null && !n.Wanted && !n.Loading.Cancelled) CancelLoad(n.Loading);
            }
            Start();
        }


        // Marks the proxies with a tile below them showing its buildings (one pass, bottom-up).
        bool Cover(Node n)
        {
            bool covered = false;
            foreach (string t in n.Entry.tiles ?? None) covered |= TileShown(t);
            foreach (int c in n.Children) covered |= Cover(nodes[c]);
            return n.Covered = covered;
        }

        void Want(Node n)
        {
            bool covered = n.Covered;
            bool refinable = n.Children.Length > 0 && (n.Entry.tiles == null || n.Entry.tiles.Length == 0);
            if (!covered && (!refinable || (n.Sse <= settings.MaximumScreenSpaceError && !n.Failed && !ChildrenLighter(n))))
            {
                n.Wanted = true;
                return;
            }
            foreach (int c in n.Children) Want(nodes[c]);
        }

        // Whether n's children, with the mip levels each may leave out, hold less than half of n's
        // texture bytes (tiles.json's atlas_px: since 0.6.0 each proxy's atlas is as large as its
        // error needs; without it every atlas counts as the same size, as before): a coarse proxy
        // seen close keeps its whole atlas, where its finer children seen as close may leave out
        // levels (their texel is finer), so refining costs less memory. Once refined so, n stays
        // refined until its children would hold twice its bytes (no loading back and forth while
        // the camera moves along the boundary).
        bool ChildrenLighter(Node n)
        {
            if (!(settings.ProxyTextureScreenSpaceError > 0)) return false;
            bool sized = n.Entry.atlas_px > 0;
            foreach (int c in n.Children) sized &= nodes[c].Entry.atlas_px > 0;
            double children = 0;
            foreach (int c in n.Children) children += AtlasTexels(nodes[c], sized);
            return n.RefinedLighter = children < (n.RefinedLighter ? 2 : 0.5) * AtlasTexels(n, sized);
        }

        // Texels of m's atlas with its NeedLimit finest mip levels left out: atlas_px's when sized
        // (a level left out halves the side, down to one texel), else relative to a whole atlas.
        static double AtlasTexels(Node m, bool sized)
        {
            if (!sized) return Math.Pow(0.25, m.NeedLimit);
            double side = Math.Max(1.0, m.Entry.atlas_px / Math.Pow(2, m.NeedLimit));
            return side * side;
        }

        // Adds what shows for n's region to show; returns whether that region is complete (every
        // wanted proxy under it shows, or a loaded ancestor stands in).
        bool Show(Node n)
        {
            if (n.Wanted)
            {
                if (n.Handle != null) { show.Add(n); return true; }
                ShowLoadedBelow(n);
                return false;
            }
            int start = show.Count;
            bool complete = true;
            foreach (int c in n.Children) complete &= Show(nodes[c]);
            if (!complete && n.Handle != null)
            {
                // The coarser proxy holds until its finer ones have all arrived (also over a tile
                // of it showing its buildings: drawn twice rather than a hole).
                show.RemoveRange(start, show.Count - start);
                show.Add(n);
                return true;
            }
            return complete;
        }

        void ShowLoadedBelow(Node n)
        {
            foreach (int c in n.Children)
            {
                Node child = nodes[c];
                if (child.Handle != null) show.Add(child);
                else ShowLoadedBelow(child);
            }
        }

        void Finish()
        {
            for (int i = 0; i < inFlight.Count; i++)
            {
                Job job = inFlight[i];
                if (!job.Task.IsCompleted) continue;
                inFlight.RemoveAt(i--);
                Take(job);
            }
            for (int i = 0; i < draining.Count; i++)
            {
                Job job = draining[i];
                if (!job.Task.IsCompleted) continue;
                draining.RemoveAt(i--);
                Take(job);
            }
        }

        void Take(Job job)
        {
            object result = null;
            if (job.Task.IsFaulted)
            {
                if (!job.Cancelled) Safe(() => backend.Report(job.Node.Entry.file + ": " + Innermost(job.Task.Exception).Message));
            }
            else if (!job.Task.IsCanceled) result = job.Task.Result;
            if (job.Node.Loading == job) job.Node.Loading = null;
            if (result == null)
            {
                // Reported. A proxy not shown yet: its children stand in; a shown one keeps its coarser textures.
                if (!job.Cancelled && !disposed)
                {
                    if (job.Node.Handle != null) job.Node.FinerFailed = true;
                    else job.Node.Failed = true;
                }
                return;
            }
            if (job.Cancelled || disposed)
            {
                Safe(() => backend.ReleaseProxy(result));
                return;
            }
            Node n = job.Node;
            if (n.Handle != null)
            {
                // Finer textures for a proxy already shown (the camera came closer): the new one
                // takes its place at once, the old one goes.
                object old = n.Handle;
                budget.Remove(n.Bytes);
                if (n.Visible) ShowProxy(result, true);
                Safe(() => backend.ReleaseProxy(old));
                Event("reload " + n.Entry.name);
            }
            n.Handle = result;
            n.Limit = job.Limit;
            long bytes = 0;
            Safe(() => bytes = backend.TextureBytes(result));
            n.Bytes = Math.Max(bytes, 0);
            budget.Add(n.Bytes);
        }

        void Release(Node n)
        {
            object h = n.Handle;
            n.Handle = null;
            if (n.Visible)
            {
                n.Visible = false;
                Event("hide " + n.Entry.name);
            }
            budget.Remove(n.Bytes);
            n.Bytes = 0;
            Safe(() => backend.ReleaseProxy(h));
            Event("unload " + n.Entry.name);
        }

        void CancelLoad(Job job)
        {
            job.Cancelled = true;
            try
            {
                job.Cancel.Cancel();
            }
            catch (Exception e)
            {
                Safe(() => backend.Report(job.Node.Entry.file + ": cancelling its load: " + Innermost(e).Message));
            }
            if (job.Node.Loading == job) job.Node.Loading = null;
            if (inFlight.Remove(job)) draining.Add(job); // its slot is free now
        }

        void Start()
        {
            waiting.Clear();
            foreach (Node n in nodes)
            {
                if (n.Handle != null || n.Loading != null || n.Failed) continue;
                if (n.Wanted && !(BuildingsComing(n) && AncestorLoaded(n))) waiting.Add(n);
            }
            if (waiting.Count > 1) waiting.Sort(CoarsestNearestFirst);
            int holes = waiting.Count;
            // Then, after every proxy a view lacks: finer textures for wanted proxies the camera came near.
            foreach (Node n in nodes)
                if (n.Handle != null && n.Loading == null && n.Wanted && !n.FinerFailed && n.NeedLimit < n.Limit) waiting.Add(n);
            if (waiting.Count - holes > 1) waiting.Sort(holes, waiting.Count - holes, CoarsestNearestFirst);
            foreach (Node n in waiting)
            {
                if (inFlight.Count >= settings.MaxConcurrentLoads) return;
                var job = new Job { Node = n, Limit = n.NeedLimit };
                n.Loading = job;
                Event((n.Handle != null ? "load finer " : "load ") + n.Entry.name);
                CancellationToken token = job.Cancel.Token;
                ProxyEntry entry = n.Entry;
                int limit = job.Limit;
                job.Task = StreamingCalls.Call(() => backend.LoadProxy(entry, limit, token));
                inFlight.Add(job);
                MaxInFlightSeen = Math.Max(MaxInFlightSeen, inFlight.Count);
            }
        }

        /// <summary>Whether a proxy shown now (at the last Update) is over the building tile named.</summary>
        public bool Covers(string tileName)
        {
            int t;
            return tileIndex.TryGetValue(tileName, out t) && drawnOver[t];
        }

        // n's Tiles: the building tiles under it and its descendants.
        int[] Gather(Node n)
        {
            var all = new List<int>();
            foreach (string name in n.Entry.tiles ?? None)
            {
                int t;
                if (!tileIndex.TryGetValue(name, out t)) { t = tileNames.Count; tileIndex[name] = t; tileNames.Add(name); }
                all.Add(t);
            }
            foreach (int c in n.Children) all.AddRange(Gather(nodes[c]));
            return n.Tiles = all.ToArray();
        }

        // Every building tile directly under n is loading its buildings.
        bool BuildingsComing(Node n)
        {
            string[] tiles = n.Entry.tiles ?? None;
            if (tiles.Length == 0) return false;
            foreach (string t in tiles) if (!TileLoading(t)) return false;
            return true;
        }

        bool AncestorLoaded(Node n)
        {
            for (int p = n.Parent; p >= 0; p = nodes[p].Parent) if (nodes[p].Handle != null) return true;
            return false;
        }

        /// <summary>Cancels every load and releases every proxy; never throws.</summary>
        public void Dispose()
        {
            if (disposed) return;
            disposed = true;
            foreach (Node n in nodes) if (n.Handle != null) Release(n);
            for (int i = inFlight.Count - 1; i >= 0; i--) CancelLoad(inFlight[i]);
            foreach (Job job in draining)
            {
                if (job.Task.IsCompleted) { Take(job); continue; }
                Job pending = job;
                job.Task.ContinueWith(t => Take(pending), CancellationToken.None, TaskContinuationOptions.ExecuteSynchronously, TaskScheduler.Default);
            }
            draining.Clear();
        }

        // The lambda lives here: in Update's loop it would allocate its captured variables for
        // every proxy at every frame (C# makes the closure where they are declared).
        void ShowProxy(object handle, bool visible)
        {
            Safe(() => backend.ShowProxy(handle, visible));
        }

        void Event(string text)
        {
            Action<string> handler = OnEvent;
            if (handler != null) Safe(() => handler(text));
        }

        void Safe(Action action)
        {
            StreamingCalls.Safe(action, backend.Report, "VWorld LoD proxies: ");
        }

        static Exception Innermost(Exception e)
        {
            return StreamingCalls.Innermost(e);
        }
    }
}
