// What the proxy streamer (ProxyStreamer) asks of the engine side: load one proxy .glb placed at
// its tile's frame, show or hide it, release it, report problems. Inside Unity this is
// GltfProxyBackend (glTFast); the tests use a fake. Same contract as IStreamingBackend: calls on
// the streamer's thread; a load completes with null when it failed (reported, naming the file) or
// was cancelled; a result that arrives for a cancelled load is released by the streamer.
using System.Threading;
using System.Threading.Tasks;

namespace VWorldLod
{
    public interface IProxyBackend
    {
        /// <summary>
        /// Loads the proxy's .glb, placed and hidden; returns a handle. mipmapLimit: how many of
        /// its textures' finest mip levels to leave out (0: whole; each one halves the texels a
        /// side: a quarter of the bytes), as Unity's mipmap limit does, keeping at least one level.
        /// </summary>
        Task<object> LoadProxy(ProxyEntry proxy, int mipmapLimit, CancellationToken cancellation);

        /// <summary>Shows or hides a loaded proxy.</summary>
        void ShowProxy(object loaded, bool visible);

        /// <summary>Bytes its textures take as Unity allocated them (for the texture budget).</summary>
        long TextureBytes(object loaded);

        /// <summary>Frees a loaded proxy.</summary>
        void ReleaseProxy(object loaded);

        /// <summary>A problem for the console (already names the file).</summary>
        void Report(string message);
    }
}
