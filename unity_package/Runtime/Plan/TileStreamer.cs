// Streams the tiles of a tile index around a moving camera. Plain C# (no Unity type), driven by
// Update(camera position) once a frame; all I/O goes through an IStreamingBackend.
//
// Flat steps per Update:
//   1. finish: loads that completed since the last frame are taken in (or released when their
//      tile was unloaded meanwhile);
//   2. select: tiles whose centre is further than UnloadRadius are unloaded (their loads
//      cancelled), tiles within LoadRadius that are not loaded are loaded, nearest first;
//   3. start: loads are started while fewer than MaxConcurrentLoads are in flight, in this order:
//      a tile's manifest first (nearest tile first), then building levels coarsest first over all
//      loaded tiles (every building's last level, then the one before, ... LOD0 last), nearer
//      tiles first within a pass. So what is visible appears quickly and gets finer.
// Positions are scene positions of tile centres (Unity units), computed once by the caller's
// function (GeoOrigin.ScenePosition or the globe placement) and again after Reposition().
//
// Cancellation never throws: an unloaded tile's loads are cancelled and stay counted as in flight
// until they finish (so the concurrency cap bounds real work); what they return is released.
// Dispose() (the component destroyed) cancels everything and releases results as they arrive.
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
            public bool PlanRequested, Failed, Unloaded;
            public TilePlan Plan;
            public List<Job> Queue;
            public int Next;
            public List<int>[] Levels;
            public List<object>[] Handles;
        }

        sealed class Job
        {
            public ActiveTile Tile;
            public int Building = -1, Level = -1, Pass = -1;
            public Task Task;
            public bool Cancelled;
        }

        readonly TileIndexEntry[] tiles;
        readonly Func<TileIndexEntry, double[]> position;
        readonly StreamingSettings settings;
        readonly IStreamingBackend backend;
        double[][] positions;
        readonly double[] distances;
        readonly Dictionary<int, ActiveTile> active = new Dictionary<int, ActiveTile>();
        readonly Dictionary<string, int> indexOf = new Dictionary<string, int>();
        readonly List<Job> inFlight = new List<Job>();
        bool disposed;

        /// <summary>Called with "load &lt;tile&gt;", "unload &lt;tile&gt;", "request &lt;tile&gt;" and "request &lt;tile&gt; &lt;building&gt; &lt;level&gt;".</summary>
        public Action<string> OnEvent;

        /// <summary>The most loads in flight at once so far.</summary>
        public int MaxInFlightSeen { get; private set; }

        public int InFlight { get { return inFlight.Count; } }

        public TileStreamer(TileIndexEntry[] tiles, Func<TileIndexEntry, double[]> position, StreamingSettings settings, IStreamingBackend backend)
        {
            string problem = settings.Problem();
            if (problem != null) throw new ArgumentException(problem);
            this.tiles = tiles;
            this.position = position;
            this.settings = settings;
            this.backend = backend;
            distances = new double[tiles.Length];
            for (int i = 0; i < tiles.Length; i++) indexOf[tiles[i].name] = i;
            Reposition();
        }

        /// <summary>Recomputes the tiles' scene positions (after the georeference origin moved).</summary>
        public void Reposition()
        {
            positions = new double[tiles.Length][];
            for (int i = 0; i < tiles.Length; i++) positions[i] = position(tiles[i]);
        }

        /// <summary>Names of the loaded tiles (manifest requested or planned), in index order.</summary>
        public List<string> LoadedTiles()
        {
            var keys = new List<int>(active.Keys);
            keys.Sort();
            return keys.ConvertAll(k => tiles[k].name);
        }

        /// <summary>
        /// Whether the tile named shows (or is loading) its buildings: loaded within the radius and
        /// its manifest not failed. A proxy over it is hidden meanwhile (ProxyStreamer.TileShown).
        /// </summary>
        public bool Shows(string tileName)
        {
            int i;
            ActiveTile tile;
            return indexOf.TryGetValue(tileName, out i) && active.TryGetValue(i, out tile) && !tile.Failed;
        }

        /// <summary>One frame: finish, select around the camera (scene position), start loads.</summary>
        public void Update(double x, double y, double z)
        {
            if (disposed) return;
            Finish();
            Select(x, y, z);
            Start();
        }

        /// <summary>Cancels every load and unloads every tile; never throws.</summary>
        public void Dispose()
        {
            if (disposed) return;
            disposed = true;
            foreach (ActiveTile tile in new List<ActiveTile>(active.Values)) Unload(tile);
            active.Clear();
            foreach (Job job in inFlight)
            {
                if (job.Task.IsCompleted)
                {
                    Take(job);
                    continue;
                }
                Job pending = job;
                // Nobody polls any more: release the result where the task completes (Unity's
                // main thread, where glTFast's awaits resume).
                job.Task.ContinueWith(t => Take(pending), CancellationToken.None, TaskContinuationOptions.ExecuteSynchronously, TaskScheduler.Default);
            }
            inFlight.Clear();
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
        }

        // A completed job: its result taken in, or released when the job was cancelled.
        void Take(Job job)
        {
            object result = null;
            if (job.Task.IsFaulted)
            {
                if (!job.Cancelled) Safe(() => backend.Report(What(job) + ": " + Innermost(job.Task.Exception).Message));
            }
            else if (!job.Task.IsCanceled)
            {
                result = job.Level < 0 ? (object)((Task<TilePlan>)job.Task).Result : ((Task<object>)job.Task).Result;
            }
            ActiveTile tile = job.Tile;
            if (job.Level < 0)
            {
                var plan = (TilePlan)result;
                if (job.Cancelled || tile.Unloaded)
                {
                    if (plan != null) Safe(() => backend.UnloadTile(plan));
                    return;
                }
                if (plan == null)
                {
                    tile.Failed = true;
                    return;
                }
                Planned(tile, plan);
                return;
            }
            if (job.Cancelled || tile.Unloaded)
            {
                if (result != null) Safe(() => backend.ReleaseLevel(result));
                return;
            }
            if (result == null) return; // failed: reported by the backend; coarser/finer levels still come
            List<int> levels = tile.Levels[job.Building];
            int at = 0;
            while (at < levels.Count && levels[at] < job.Level) at++;
            levels.Insert(at, job.Level);
            tile.Handles[job.Building].Insert(at, result);
            BuildingPlan building = tile.Plan.Buildings[job.Building];
            Safe(() => backend.ShowLevels(tile.Plan, building, levels.ToArray(), tile.Handles[job.Building].ToArray()));
        }

        // The tile's level jobs, coarsest pass first, buildings in manifest order within a pass.
        static void Planned(ActiveTile tile, TilePlan plan)
        {
            tile.Plan = plan;
            int n = plan.Buildings.Length, passes = 0;
            tile.Levels = new List<int>[n];
            tile.Handles = new List<object>[n];
            for (int b = 0; b < n; b++)
            {
                tile.Levels[b] = new List<int>();
                tile.Handles[b] = new List<object>();
                passes = Math.Max(passes, plan.Buildings[b].Levels.Length);
            }
            tile.Queue = new List<Job>();
            for (int pass = 0; pass < passes; pass++)
                for (int b = 0; b < n; b++)
                {
                    int count = plan.Buildings[b].Levels.Length;
                    if (pass < count) tile.Queue.Add(new Job { Tile = tile, Building = b, Level = count - 1 - pass, Pass = pass });
                }
        }

        void Select(double x, double y, double z)
        {
            for (int i = 0; i < tiles.Length; i++)
            {
                double[] p = positions[i];
                double dy = settings.Horizontal ? 0 : p[1] - y;
                distances[i] = Math.Sqrt((p[0] - x) * (p[0] - x) + dy * dy + (p[2] - z) * (p[2] - z));
            }
            var leaving = new List<int>();
            foreach (int i in active.Keys) if (distances[i] > settings.UnloadRadius) leaving.Add(i);
            leaving.Sort();
            foreach (int i in leaving)
            {
                Unload(active[i]);
                active.Remove(i);
                Event("unload " + tiles[i].name);
            }
            var entering = new List<int>();
            for (int i = 0; i < tiles.Length; i++)
                if (distances[i] <= settings.LoadRadius && !active.ContainsKey(i)) entering.Add(i);
            entering.Sort((a, b) => distances[a] != distances[b] ? distances[a].CompareTo(distances[b]) : a.CompareTo(b));
            foreach (int i in entering)
            {
                active[i] = new ActiveTile { Entry = tiles[i], Index = i };
                Event("load " + tiles[i].name);
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
            foreach (Job job in inFlight) if (job.Tile == tile) job.Cancelled = true;
            if (tile.Plan == null) return;
            for (int b = 0; b < tile.Handles.Length; b++)
                foreach (object handle in tile.Handles[b])
                {
                    object h = handle;
                    Safe(() => backend.ReleaseLevel(h));
                }
            TilePlan plan = tile.Plan;
            Safe(() => backend.UnloadTile(plan));
        }

        void Start()
        {
            while (inFlight.Count < settings.MaxConcurrentLoads)
            {
                ActiveTile best = null;
                int bestPass = int.MaxValue;
                foreach (ActiveTile tile in active.Values)
                {
                    int pass;
                    if (tile.Failed) continue;
                    if (tile.Plan == null) { if (tile.PlanRequested) continue; pass = -1; }
                    else if (tile.Next < tile.Queue.Count) pass = tile.Queue[tile.Next].Pass;
                    else continue;
                    if (best == null || pass < bestPass || (pass == bestPass && Closer(tile.Index, best.Index)))
                    {
                        best = tile;
                        bestPass = pass;
                    }
                }
                if (best == null) return;
                Launch(best);
            }
        }

        bool Closer(int a, int b)
        {
            return distances[a] != distances[b] ? distances[a] < distances[b] : a < b;
        }

        void Launch(ActiveTile tile)
        {
            Job job;
            CancellationToken token = tile.Cancel.Token;
            if (tile.Plan == null)
            {
                tile.PlanRequested = true;
                job = new Job { Tile = tile };
                Event("request " + tile.Entry.name);
                job.Task = StreamingCalls.Call(() => backend.LoadTile(tile.Entry, token));
            }
            else
            {
                job = tile.Queue[tile.Next++];
                BuildingPlan building = tile.Plan.Buildings[job.Building];
                Event("request " + tile.Entry.name + " " + building.Id + " " + job.Level);
                int level = job.Level;
                job.Task = StreamingCalls.Call(() => backend.LoadLevel(tile.Plan, building, level, token));
            }
            inFlight.Add(job);
            MaxInFlightSeen = Math.Max(MaxInFlightSeen, inFlight.Count);
        }

        string What(Job job)
        {
            if (job.Level < 0 || job.Tile.Plan == null) return job.Tile.Entry.manifest;
            return job.Tile.Plan.Buildings[job.Building].Levels[job.Level].Path;
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
