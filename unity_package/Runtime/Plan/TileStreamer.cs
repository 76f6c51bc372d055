// Streams the tiles of a tile index around a moving camera, one resident level per building at
// the size it is seen. Plain C# (no Unity type), driven by Update(camera, view) once a frame; all
// I/O goes through an IStreamingBackend.
//
// Per Update:
//   1. finish: loads that completed since the last frame are taken in; cancelled ones that
//      completed are released;
//   2. select: tiles whose centre is further than UnloadRadius are unloaded (their loads
//      cancelled, their levels released) -- with proxies (ProxyShown), only once a proxy over the
//      tile shows: meanwhile the tile is "leaving", keeps what it holds and says it does not show
//      (so the proxy streamer brings its proxy), until 2 x UnloadRadius - LoadRadius at most;
//      tiles within LoadRadius that are not loaded are loaded, nearest first (their manifest is
//      requested);
//   3. choose, per building of each planned tile (LevelChoice): the level it needs at its distance
//      (the LODGroup's transitions, or finer where that level's error_m would show more than
//      LevelMaximumScreenSpaceError), and while the camera approaches the next finer one once the
//      building's screen size times PrefetchFactor reaches it. A resident level no longer needed
//      is released once the needed one shows (never leaving a building with nothing while its
//      level loads), unless it is within KeepFactor of being needed and the texture budget has
//      room. Loads of levels no longer wanted are cancelled: their slot frees at once;
//   4. start loads while fewer than MaxConcurrentLoads are in flight: manifests (nearest tile
//      first), then needed levels of buildings showing nothing, then needed levels of buildings
//      showing another one, then prefetches within the texture budget; nearest first each.
// A tile "shows" (Shows: the proxy over it may hide) once its manifest is planned and every one
// of its buildings the view needs shows a level. Texture bytes are accounted from the manifest
// (texture_size per level, TextureBudget); passing the budget is said once in the console.
//
// Positions are scene positions (Unity units): tile centres from the caller's function
// (GeoOrigin.ScenePosition or the globe placement), buildings at their tile root's pose
// (TilePose, by default the tile centre with the scene's axes East/Up/North as under a
// georeference) composed with relative_placement and LOD0's bounds centre; computed again after
// Reposition(). Level distances are in metres (scene units / (UR/R)).
//
// Cancellation never throws and frees the load's slot at once: the load is set aside and its
// result, when it comes, is released. Dispose() (the component destroyed) cancels everything and
// releases results as they arrive. Update allocates nothing in a steady state (buffers are
// fields); arrays for ShowLevels are made only when a building's resident levels change.
using System;
using System.Collections.Generic;
using System.Threading;
using System.Threading.Tasks;

namespace VWorldLod
{
    public sealed class TileStreamer : IDisposable
    {
        sealed class ActiveTile
        {
            public TileIndexEntry Entry;
            public int Index;
            public readonly CancellationTokenSource Cancel = new CancellationTokenSource();
            public bool PlanRequested, Failed, Unloaded, Complete, Leaving;
            public TilePlan Plan;
            public Building[] Buildings;
        }

        sealed class Building
        {
            public ActiveTile Tile;
            public BuildingPlan Plan;
            public object[] Handles; // per level, resident
            public Job[] Loading;    // per level, in flight
            public bool[] Failed;    // per level, its load failed (reported)
            public long[] Bytes;     // per level, texture bytes as Unity allocates them
            public int Resident;
            public double X, Y, Z;   // scene position of LOD0's bounds centre, Unity units
            public double Distance = double.PositiveInfinity; // metres, last frame
            public int Needed = -1, Prefetch = -1, KeepFine = -1, KeepCoarse = -1;
            public bool Changed, Approaching; // Approaching: the distance shrank when it last changed
        }

        sealed class Job
        {
            public ActiveTile Tile;
            public Building Building;
            public int Level = -1;
            public Task Task;
            public CancellationTokenSource Cancel; // a level's own, linked to its tile's
            public bool Cancelled;
        }

        sealed class NearestFirst : IComparer<int>
        {
            public double[] Distances;
            public int Compare(int a, int b)
            {
                return Distances[a] != Distances[b] ? Distances[a].CompareTo(Distances[b]) : a.CompareTo(b);
            }
        }

        /// <summary>A building's coarsest level is loaded from this factor beyond its culling distance.</summary>
        public const double CullMargin = 1.1;

        readonly TileIndexEntry[] tiles;
        readonly Func<TileIndexEntry, double[]> position;
        readonly StreamingSettings settings;
        readonly IStreamingBackend backend;
        readonly TextureBudget budget;
        double[][] positions;
        readonly double[] distances;
        readonly ActiveTile[] byIndex;
        readonly List<ActiveTile> active = new List<ActiveTile>();
        readonly Dictionary<string, int> indexOf = new Dictionary<string, int>();
        readonly List<Job> inFlight = new List<Job>();
        readonly List<Job> draining = new List<Job>(); // cancelled, not finished yet
        readonly List<int> entering = new List<int>();
        readonly NearestFirst nearestFirst = new NearestFirst();
        readonly Action<string> report;
        bool disposed;

        /// <summary>Called with "load|unload|request &lt;tile&gt;" and "request|release|cancel &lt;tile&gt; &lt;building&gt; &lt;level&gt;".</summary>
        public Action<string> OnEvent;

        /// <summary>
        /// The tile root's scene pose (buildings at Compose(pose, relative_placement)); null: the
        /// tile centre's scene position, the scene's axes East/Up/North, scale UR/R.
        /// </summary>
        public Func<TilePlan, Placement> TilePose;

        /// <summary>
        /// Whether a proxy over the tile named shows (ProxyStreamer.Covers): a tile beyond the
        /// unload radius keeps its buildings until then. Null (no proxies): tiles unload at once.
        /// </summary>
        public Func<string, bool> ProxyShown;

        /// <summary>The most loads in flight at once so far.</summary>
        public int MaxInFlightSeen { get; private set; }

        /// <summary>Loads holding a slot (cancelled ones do not).</summary>
        public int InFlight { get { return inFlight.Count; } }

        /// <summary>Cancelled loads not finished yet (their results will be released).</summary>
        public int Draining { get { return draining.Count; } }

        /// <summary>The texture memory held (shared with a ProxyStreamer given the same budget).</summary>
        public TextureBudget Budget { get { return budget; } }

        /// <summary>budget: shared with the ProxyStreamer; null makes one of settings.</summary>
        public TileStreamer(TileIndexEntry[] tiles, Func<TileIndexEntry, double[]> position, StreamingSettings settings, IStreamingBackend backend, TextureBudget budget = null)
        {
            string problem = settings.Problem();
            if (problem != null) throw new ArgumentException(problem);
            this.tiles = tiles;
            this.position = position;
            this.settings = settings;
            this.backend = backend;
            this.budget = budget ?? new TextureBudget(settings);
            report = message => Safe(() => backend.Report(message));
            distances = new double[tiles.Length];
            byIndex = new ActiveTile[tiles.Length];
            nearestFirst.Distances = distances;
            for (int i = 0; i < tiles.Length; i++) indexOf[tiles[i].name] = i;
            Reposition();
        }

        /// <summary>Recomputes the tiles' and buildings' scene positions (after the georeference origin moved).</summary>
        public void Reposition()
        {
            positions = new double[tiles.Length][];
            for (int i = 0; i < tiles.Length; i++) positions[i] = position(tiles[i]);
            foreach (ActiveTile tile in active) if (tile.Plan != null) Place(tile);
        }

        /// <summary>Names of the loaded tiles (manifest requested or planned), in index order.</summary>
        public List<string> LoadedTiles()
        {
            var names = new List<string>();
            for (int i = 0; i < byIndex.Length; i++) if (byIndex[i] != null) names.Add(tiles[i].name);
            return names;
        }

        /// <summary>The resident levels of a building of a loaded tile (ascending), empty when none.</summary>
        public List<int> ResidentLevels(string tileName, string buildingId)
        {
            var levels = new List<int>();
            int i;
            if (!indexOf.TryGetValue(tileName, out i) || byIndex[i] == null || byIndex[i].Buildings == null) return levels;
            foreach (Building b in byIndex[i].Buildings)
                if (b.Plan.Id == buildingId)
                    for (int k = 0; k < b.Handles.Length; k++) if (b.Handles[k] != null) levels.Add(k);
            return levels;
        }

        /// <summary>
        /// Whether the tile named shows its buildings: loaded within the radius, its manifest
        /// planned, and every building the view needs showing a level (one whose every level
        /// failed counts as shown: reported). A proxy over it stays until then (ProxyStreamer.TileShown).
        /// </summary>
        public bool Shows(string tileName)
        {
            int i;
            return indexOf.TryGetValue(tileName, out i) && byIndex[i] != null && byIndex[i].Complete;
        }

        /// <summary>Whether the tile named is loading its buildings: within the radius, its manifest not failed, not shown yet.</summary>
        public bool Loading(string tileName)
        {
            int i;
            return indexOf.TryGetValue(tileName, out i) && byIndex[i] != null && !byIndex[i].Failed && !byIndex[i].Complete && !byIndex[i].Leaving;
        }

        /// <summary>One frame with a 1080-pixel, 60-degree view and LOD bias 1 (see the other overload).</summary>
        public void Update(double x, double y, double z)
        {
            Update(x, y, z, 1080, 60, 1);
        }

        /// <summary>
        /// One frame: camera at scene position (x, y, z); screenHeight pixels, vertical field of
        /// view in degrees and QualitySettings.lodBias (as LODGroup uses them).
        /// </summary>
        public void Update(double x, double y, double z, double screenHeight, double fovDegrees, double lodBias)
        {
            if (disposed) return;
            Finish();
            Select(x, y, z);
            for (int t = 0; t < active.Count; t++) Choose(active[t], x, y, z, screenHeight, fovDegrees, lodBias);
            if (budget.Over()) for (int t = 0; t < active.Count; t++) Trim(active[t]);
            for (int t = 0; t < active.Count; t++) ShowChanged(active[t]);
            Start();
            budget.WarnIfOver(report);
        }

        /// <summary>Cancels every load and unloads every tile; never throws.</summary>
        public void Dispose()
        {
            if (disposed) return;
            disposed = true;
            foreach (ActiveTile tile in active) Unload(tile);
            active.Clear();
            Array.Clear(byIndex, 0, byIndex.Length);
            foreach (Job job in draining)
            {
                if (job.Task.IsCompleted)
                {
                    Drained(job);
                    continue;
                }
                Job pending = job;
                // Nobody polls any more: release the result where the task completes (Unity's
                // main thread, where glTFast's awaits resume).
                job.Task.ContinueWith(t => Drained(pending), CancellationToken.None, TaskContinuationOptions.ExecuteSynchronously, TaskScheduler.Default);
            }
            draining.Clear();
        }

        void Finish()
        {
            for (int i = 0; i < inFlight.Count; i++)
            {
                if (!inFlight[i].Task.IsCompleted) continue;
                Job job = inFlight[i];
                inFlight.RemoveAt(i--);
                Take(job);
            }
            for (int i = 0; i < draining.Count; i++)
            {
                if (!draining[i].Task.IsCompleted) continue;
                Job job = draining[i];
                draining.RemoveAt(i--);
                Drained(job);
            }
        }

        // What the job's task returned (null when it failed, was cancelled or faulted; a fault is
        // reported unless the job was cancelled).
        object Result(Job job)
        {
            if (job.Cancel != null) job.Cancel.Dispose();
            if (job.Task.IsFaulted)
            {
                if (!job.Cancelled) Safe(() => backend.Report(What(job) + ": " + Innermost(job.Task.Exception).Message));
                return null;
            }
            if (job.Task.IsCanceled) return null;
            return job.Level < 0 ? (object)((Task<TilePlan>)job.Task).Result : ((Task<object>)job.Task).Result;
        }

        // A cancelled job that completed: whatever it made is released.
        void Drained(Job job)
        {
            object result = Result(job);
            if (result == null) return;
            if (job.Level < 0) Safe(() => backend.UnloadTile((TilePlan)result));
            else Safe(() => backend.ReleaseLevel(result));
        }

        // A completed job: its result taken in.
        void Take(Job job)
        {
            object result = Result(job);
            ActiveTile tile = job.Tile;
            if (job.Level < 0)
            {
                var plan = (TilePlan)result;
                if (plan == null) tile.Failed = true;
                else Planned(tile, plan);
                return;
            }
            Building b = job.Building;
            if (b.Loading[job.Level] == job) b.Loading[job.Level] = null;
            if (result == null)
            {
                b.Failed[job.Level] = true; // reported by the backend; another level stands in
                return;
            }
            b.Handles[job.Level] = result;
            budget.Add(b.Bytes[job.Level]);
            b.Resident++;
            b.Changed = true;
        }

        void Planned(ActiveTile tile, TilePlan plan)
        {
            tile.Plan = plan;
            tile.Buildings = new Building[plan.Buildings.Length];
            for (int i = 0; i < tile.Buildings.Length; i++)
            {
                BuildingPlan p = plan.Buildings[i];
                int n = p.Levels.Length;
                var b = new Building { Tile = tile, Plan = p, Handles = new object[n], Loading = new Job[n], Failed = new bool[n], Bytes = new long[n] };
                for (int k = 0; k < n; k++) b.Bytes[k] = budget.Bytes(p.Levels[k].TextureWidth, p.Levels[k].TextureHeight);
                tile.Buildings[i] = b;
            }
            Place(tile);
        }

        void Place(ActiveTile tile)
        {
            Placement root;
            if (TilePose != null) root = TilePose(tile.Plan);
            else
            {
                double[] p = positions[tile.Index];
                root = new Placement(p[0], p[1], p[2], 0, 0, 0, 1, UnitsPerMetre(tile));
            }
            foreach (Building b in tile.Buildings)
            {
                double[] c = b.Plan.Center;
                Placement at = Placement.Compose(root, Placement.Compose(b.Plan.Relative, new Placement(c[0], c[1], c[2], 0, 0, 0, 1, 1)));
                b.X = at.px;
                b.Y = at.py;
                b.Z = at.pz;
            }
        }

        static double UnitsPerMetre(ActiveTile tile)
        {
            GlobeInfo g = tile.Entry.globe;
            return g != null && g.earth_radius_m > 0 && g.unity_radius > 0 ? g.unity_radius / g.earth_radius_m : 1;
        }

        void Select(double x, double y, double z)
        {
            for (int i = 0; i < tiles.Length; i++)
            {
                double[] p = positions[i];
                double dy = settings.Horizontal ? 0 : p[1] - y;
                distances[i] = Math.Sqrt((p[0] - x) * (p[0] - x) + dy * dy + (p[2] - z) * (p[2] - z));
            }
            double farthest = 2 * settings.UnloadRadius - settings.LoadRadius;
            for (int t = 0; t < active.Count; t++)
            {
                ActiveTile tile = active[t];
                double d = distances[tile.Index];
                tile.Leaving = d > settings.UnloadRadius;
                if (!tile.Leaving) continue;
                bool standIn = ProxyShown == null || tile.Plan == null || tile.Failed || d > farthest;
                if (!standIn)
                {
                    bool shown = true;
                    try
                    {
                        shown = ProxyShown(tile.Entry.name);
                    }
                    catch (Exception e)
                    {
                        Tell(tile.Entry.name + ": asking for its proxy: " + Innermost(e).Message);
                    }
                    if (!shown) continue; // its buildings hold until the proxy over it shows
                }
                Unload(tile);
                active.RemoveAt(t--);
                byIndex[tile.Index] = null;
                Event("unload " + tile.Entry.name);
            }
            entering.Clear();
            for (int i = 0; i < tiles.Length; i++)
                if (distances[i] <= settings.LoadRadius && byIndex[i] == null) entering.Add(i);
            if (entering.Count > 1) entering.Sort(nearestFirst);
            foreach (int i in entering)
            {
                var tile = new ActiveTile { Entry = tiles[i], Index = i };
                byIndex[i] = tile;
                active.Add(tile);
                Event("load " + tiles[i].name);
            }
        }

        // The levels each building of the tile needs, and what it no longer needs released.
        void Choose(ActiveTile tile, double x, double y, double z, double screenHeight, double fov, double lodBias)
        {
            if (tile.Plan == null || tile.Leaving)
            {
                tile.Complete = false;
                return;
            }
            double perMetre = UnitsPerMetre(tile);
            double maxPx = settings.LevelMaximumScreenSpaceError;
            double prefetch = settings.PrefetchFactor, keep = settings.KeepFactor;
            bool complete = !tile.Failed;
            foreach (Building b in tile.Buildings)
            {
                double d = Math.Sqrt((b.X - x) * (b.X - x) + (b.Y - y) * (b.Y - y) + (b.Z - z) * (b.Z - z)) / perMetre;
                if (d != b.Distance) b.Approaching = d < b.Distance;
                b.Distance = d;
                BuildingPlan p = b.Plan;
                int needed = LevelChoice.Needed(p, d, screenHeight, fov, lodBias, maxPx);
                // From CullMargin beyond where its LODGroup starts drawing it: Unity's bounds and
                // distance differ a little from the manifest's, and it should show from the start.
                if (needed < 0) needed = LevelChoice.Needed(p, d / CullMargin, screenHeight, fov, lodBias, maxPx);
                b.Needed = Usable(b, needed);
                b.Prefetch = -1;
                if (b.Approaching && b.Needed > 0)
                {
                    int ahead = Usable(b, LevelChoice.Needed(p, d / prefetch, screenHeight, fov, lodBias, maxPx));
                    if (ahead >= 0 && ahead < b.Needed) b.Prefetch = b.Needed - 1;
                }
                // Kept while within KeepFactor of being needed: [KeepFine, KeepCoarse], KeepCoarse -1 = up to the last.
                b.KeepFine = LevelChoice.Needed(p, d / keep, screenHeight, fov, lodBias, maxPx);
                b.KeepCoarse = LevelChoice.Needed(p, d * keep, screenHeight, fov, lodBias, maxPx);
                bool neededShows = b.Needed < 0 || b.Handles[b.Needed] != null;
                for (int k = 0; k < b.Handles.Length; k++)
                {
                    if (b.Loading[k] != null && k != b.Needed && k != b.Prefetch) CancelLoad(b.Loading[k]);
                    if (b.Handles[k] == null || !neededShows || k == b.Needed || k == b.Prefetch) continue;
                    bool kept = b.KeepFine >= 0 && k >= b.KeepFine && (b.KeepCoarse < 0 || k <= b.KeepCoarse);
                    if (!kept) Release(b, k);
                }
                if (b.Needed >= 0 && b.Resident == 0) complete = false;
            }
            tile.Complete = complete;
        }

        // Over the budget: levels the view does not need (kept or prefetched) go, where the needed one shows.
        void Trim(ActiveTile tile)
        {
            if (tile.Plan == null || tile.Leaving) return; // a leaving tile holds what it shows until its proxy does
            foreach (Building b in tile.Buildings)
            {
                if (b.Needed >= 0 && b.Handles[b.Needed] == null) continue;
                for (int k = 0; k < b.Handles.Length; k++)
                    if (b.Handles[k] != null && k != b.Needed) Release(b, k);
            }
        }

        // level, or when it failed to load the nearest level that did not (coarser first); -1 when none is left.
        static int Usable(Building b, int level)
        {
            if (level < 0 || !b.Failed[level]) return level;
            for (int step = 1; step < b.Failed.Length; step++)
            {
                if (level + step < b.Failed.Length && !b.Failed[level + step]) return level + step;
                if (level - step >= 0 && !b.Failed[level - step]) return level - step;
            }
            return -1;
        }

        void Release(Building b, int level)
        {
            object h = b.Handles[level];
            b.Handles[level] = null;
            budget.Remove(b.Bytes[level]);
            b.Resident--;
            b.Changed = true;
            Safe(() => backend.ReleaseLevel(h));
            if (OnEvent != null) Event("release " + b.Tile.Entry.name + " " + b.Plan.Id + " " + level);
        }

        void ShowChanged(ActiveTile tile)
        {
            if (tile.Plan == null) return;
            foreach (Building b in tile.Buildings)
            {
                if (!b.Changed) continue;
                b.Changed = false;
                var levels = new int[b.Resident];
                var handles = new object[b.Resident];
                for (int k = 0, i = 0; k < b.Handles.Length; k++)
                {
                    if (b.Handles[k] == null) continue;
                    levels[i] = k;
                    handles[i++] = b.Handles[k];
                }
                ShowLevels(tile.Plan, b.Plan, levels, handles);
            }
        }

        void Unload(ActiveTile tile)
        {
            tile.Unloaded = true;
            try
            {
                tile.Cancel.Cancel();
            }
            catch (Exception e)
            {
                // A token callback registered by a loader threw; cancellation goes on regardless.
                Safe(() => backend.Report(tile.Entry.name + ": cancelling its loads: " + Innermost(e).Message));
            }
            for (int i = 0; i < inFlight.Count; i++)
            {
                Job job = inFlight[i];
                if (job.Tile != tile) continue;
                job.Cancelled = true;
                inFlight.RemoveAt(i--);
                draining.Add(job);
            }
            if (tile.Plan == null) return;
            foreach (Building b in tile.Buildings)
                for (int k = 0; k < b.Handles.Length; k++)
                {
                    b.Loading[k] = null;
                    if (b.Handles[k] == null) continue;
                    object h = b.Handles[k];
                    b.Handles[k] = null;
                    budget.Remove(b.Bytes[k]);
                    Safe(() => backend.ReleaseLevel(h));
                }
            TilePlan plan = tile.Plan;
            Safe(() => backend.UnloadTile(plan));
        }

        // A level no longer wanted: its load is cancelled and its slot freed now.
        void CancelLoad(Job job)
        {
            job.Cancelled = true;
            job.Building.Loading[job.Level] = null;
            try
            {
                job.Cancel.Cancel();
            }
            catch (Exception e)
            {
                Safe(() => backend.Report(What(job) + ": cancelling its load: " + Innermost(e).Message));
            }
            inFlight.Remove(job);
            draining.Add(job);
            if (OnEvent != null) Event("cancel " + job.Tile.Entry.name + " " + job.Building.Plan.Id + " " + job.Level);
        }

        void Start()
        {
            while (inFlight.Count < settings.MaxConcurrentLoads)
            {
                ActiveTile manifest = null;
                Building best = null;
                int bestLevel = -1, bestRank = int.MaxValue;
                foreach (ActiveTile tile in active)
                {
                    if (tile.Failed || tile.Leaving) continue;
                    if (tile.Plan == null)
                    {
                        if (!tile.PlanRequested && (manifest == null || Closer(tile.Index, manifest.Index))) manifest = tile;
                        continue;
                    }
                    foreach (Building b in tile.Buildings)
                    {
                        int level = -1, rank;
                        if (b.Needed >= 0 && b.Handles[b.Needed] == null && b.Loading[b.Needed] == null) { level = b.Needed; rank = b.Resident == 0 ? 0 : 1; }
                        else if (b.Prefetch >= 0 && b.Handles[b.Prefetch] == null && b.Loading[b.Prefetch] == null && !budget.Over(b.Bytes[b.Prefetch])) { level = b.Prefetch; rank = 2; }
                        else continue;
                        if (rank < bestRank || (rank == bestRank && b.Distance < best.Distance))
                        {
                            best = b;
                            bestLevel = level;
                            bestRank = rank;
                        }
                    }
                }
                if (manifest != null) LaunchManifest(manifest);
                else if (best != null) LaunchLevel(best, bestLevel);
                else return;
            }
        }

        bool Closer(int a, int b)
        {
            return distances[a] != distances[b] ? distances[a] < distances[b] : a < b;
        }

        void LaunchManifest(ActiveTile tile)
        {
            tile.PlanRequested = true;
            var job = new Job { Tile = tile };
            CancellationToken token = tile.Cancel.Token;
            Event("request " + tile.Entry.name);
            job.Task = StreamingCalls.Call(() => backend.LoadTile(tile.Entry, token));
            Launched(job);
        }

        void LaunchLevel(Building b, int level)
        {
            var job = new Job { Tile = b.Tile, Building = b, Level = level, Cancel = CancellationTokenSource.CreateLinkedTokenSource(b.Tile.Cancel.Token) };
            b.Loading[level] = job;
            CancellationToken token = job.Cancel.Token;
            TilePlan plan = b.Tile.Plan;
            BuildingPlan building = b.Plan;
            Event("request " + b.Tile.Entry.name + " " + building.Id + " " + level);
            job.Task = StreamingCalls.Call(() => backend.LoadLevel(plan, building, level, token));
            Launched(job);
        }

        void Launched(Job job)
        {
            inFlight.Add(job);
            MaxInFlightSeen = Math.Max(MaxInFlightSeen, inFlight.Count);
        }

        string What(Job job)
        {
            if (job.Level < 0 || job.Tile.Plan == null) return job.Tile.Entry.manifest;
            return job.Building.Plan.Levels[job.Level].Path;
        }

        // Lambdas live in these helpers: a lambda in Update's own methods would allocate its
        // captured variables at every call (C# makes the closure where they are declared).
        void ShowLevels(TilePlan plan, BuildingPlan building, int[] levels, object[] handles)
        {
            Safe(() => backend.ShowLevels(plan, building, levels, handles));
        }

        void Tell(string message)
        {
            Safe(() => backend.Report(message));
        }

        void Event(string text)
        {
            Action<string> handler = OnEvent;
            if (handler != null) Safe(() => handler(text));
        }

        void Safe(Action action)
        {
            StreamingCalls.Safe(action, backend.Report, "VWorld LoD streaming: ");
        }

        static Exception Innermost(Exception e)
        {
            return StreamingCalls.Innermost(e);
        }
    }
}
