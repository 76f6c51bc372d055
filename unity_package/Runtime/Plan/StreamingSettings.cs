// How the tile streamer decides: radii in scene units (Unity units: metres for UR = R) around
// the camera, and the number of loads (a manifest or one glTF level) in flight at once; beyond
// the load radius, the proxies' screen-space error limit (ProxyStreamer); which level of each
// building is resident (LevelChoice) and the texture-memory budget (TextureBudget).
using System;

namespace VWorldLod
{
    [Serializable]
    public class StreamingSettings
    {
        /// <summary>A tile whose centre comes within this distance of the camera is loaded.</summary>
        public double LoadRadius = 500;
        /// <summary>A loaded tile whose centre is further than this is unloaded (hysteresis: &gt;= LoadRadius).</summary>
        public double UnloadRadius = 650;
        /// <summary>Loads in flight at once, cancelled ones included until they have finished.</summary>
        public int MaxConcurrentLoads = 4;
        /// <summary>Measure distances in the x-z plane only (East/North under a georeference), ignoring heights.</summary>
        public bool Horizontal;
        /// <summary>Pixels: a proxy is shown when its geometric error on screen is at most this (Cesium's default 16).</summary>
        public double MaximumScreenSpaceError = 16;
        /// <summary>
        /// Pixels: a building's level is fine enough when its error (LevelPlan.ErrorM, the
        /// manifest's error_m) looks at most this large at the building's distance; a finer level
        /// than the LODGroup's transitions ask for is loaded where a coarse level's (texture)
        /// error would show more. error_m is tileset.json's geometricError: a textured level's is
        /// 4 x its on-surface texel (docs/tileset.md), so 16 (Cesium's default, as for proxies)
        /// keeps a shown level's texels within 4 pixels, where LOD0's reach 2.
        /// </summary>
        public double LevelMaximumScreenSpaceError = 16;
        /// <summary>
        /// Bytes: resident texture memory (building levels and proxies, as Unity allocates them)
        /// above which levels and proxies the view does not need (prefetched, kept for the way
        /// back) are released; needed ones still load, and the console says once that the
        /// budget is exceeded. Cesium's maximumCachedBytes plays this role (512 MiB there).
        /// </summary>
        public double TextureBudgetBytes = 512.0 * 1024 * 1024;
        /// <summary>
        /// Bytes per texel of a loaded texture: 4 for glTFast's RGBA32 (embedded JPEG/PNG), 1 for
        /// BC7 / ASTC 4x4 / ETC2 RGBA (KTX2 transcoded), 0.5 for DXT1 / BC1 / ETC2 RGB.
        /// </summary>
        public double TextureBytesPerPixel = 4;
        /// <summary>Textures carry a mip chain (+1/3 of the base level).</summary>
        public bool TextureMipmaps = true;
        /// <summary>
        /// While the camera approaches a building, the next finer level is loaded ahead once the
        /// building's screen size times this reaches that level's transition (1 = never ahead).
        /// </summary>
        public double PrefetchFactor = 1.25;
        /// <summary>
        /// A resident level no longer needed stays while the building's screen size is within
        /// this factor of where it would be needed (no reloading back and forth at a transition).
        /// </summary>
        public double KeepFactor = 1.1;
        /// <summary>
        /// Pixels: a proxy's textures are loaded without their finest mip levels
        /// (IProxyBackend.LoadProxy's mipmapLimit, each level halving the texels a side) while its
        /// atlas texel (tiles.json's texel_m, else bounded by its geometric error), doubled per
        /// level left out, looks at most this large at its distance; loaded again finer as the
        /// camera comes closer. The default 2 is what the building levels get (their error_m is 8
        /// x their texel, shown at 16 px); 16 would keep only the proxy's error within
        /// MaximumScreenSpaceError (blurrier, a little less memory); 0 loads textures whole.
        /// </summary>
        public double ProxyTextureScreenSpaceError = 2;

        /// <summary>Why these settings cannot be used, or null.</summary>
        public string Problem()
        {
            if (!(LoadRadius > 0) || double.IsInfinity(LoadRadius)) return "load radius must be a positive number, found " + LoadRadius;
            if (!(UnloadRadius >= LoadRadius) || double.IsInfinity(UnloadRadius))
                return "unload radius (" + UnloadRadius + ") must be at least the load radius (" + LoadRadius + ")";
            if (!(MaximumScreenSpaceError > 0) || double.IsInfinity(MaximumScreenSpaceError))
                return "maximum screen-space error must be a positive number of pixels, found " + MaximumScreenSpaceError;
            if (MaxConcurrentLoads < 1) return "at least one concurrent load is needed, found " + MaxConcurrentLoads;
            if (!(LevelMaximumScreenSpaceError > 0)) return "the levels' maximum screen-space error must be a positive number of pixels, found " + LevelMaximumScreenSpaceError;
            if (!(TextureBudgetBytes >= 0)) return "the texture budget must be a number of bytes >= 0, found " + TextureBudgetBytes;
            if (!(TextureBytesPerPixel > 0) || double.IsInfinity(TextureBytesPerPixel)) return "texture bytes per pixel must be a positive number, found " + TextureBytesPerPixel;
            if (!(PrefetchFactor >= 1) || double.IsInfinity(PrefetchFactor)) return "the prefetch factor must be at least 1, found " + PrefetchFactor;
            if (!(KeepFactor >= 1) || double.IsInfinity(KeepFactor)) return "the keep factor must be at least 1, found " + KeepFactor;
            if (!(ProxyTextureScreenSpaceError >= 0) || double.IsInfinity(ProxyTextureScreenSpaceError)) return "the proxies' texture screen-space error must be a number of pixels >= 0, found " + ProxyTextureScreenSpaceError;
            return null;
        }
    }
}
