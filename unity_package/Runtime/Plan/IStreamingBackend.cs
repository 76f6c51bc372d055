// What the tile streamer (TileStreamer) asks of the engine side: load a tile's plan, load one
// glTF level, show a building's resident levels, release things, report problems. Inside Unity
// this is GltfStreamingBackend (glTFast, GameObjects, LODGroups); the tests use a fake.
//
// Contract: every call is made on the streamer's thread (Unity's main thread). A task completes
// with null when the load failed (the backend has reported it, naming the file) or was cancelled;
// on cancellation the backend either returns null having released what it made, or returns the
// result, which the streamer then releases. Tasks may also fault: the streamer reports the
// exception unless the load was cancelled.
using System.Threading;
using System.Threading.Tasks;

namespace VWorldLod
{
    public interface IStreamingBackend
    {
        /// <summary>Reads and plans the tile's manifest and makes its (empty) tile root.</summary>
        Task<TilePlan> LoadTile(TileIndexEntry tile, CancellationToken cancellation);

        /// <summary>Loads level `level` of building, ready to be shown; returns a handle.</summary>
        Task<object> LoadLevel(TilePlan tile, BuildingPlan building, int level, CancellationToken cancellation);

        /// <summary>
        /// Shows the building with the levels resident now (ascending) and their handles, after
        /// each change (a level loaded or released); empty when none is resident (the building
        /// beyond its culling distance: its released levels are gone already).
        /// </summary>
        void ShowLevels(TilePlan tile, BuildingPlan building, int[] levels, object[] loaded);

        /// <summary>Frees one loaded level.</summary>
        void ReleaseLevel(object loaded);

        /// <summary>Removes the tile root (its levels have been released before).</summary>
        void UnloadTile(TilePlan tile);

        /// <summary>A problem for the console (already names the file).</summary>
        void Report(string message);
    }
}
