// How the tile streamer decides: radii in scene units (Unity units: metres for UR = R) around
// the camera, and the number of loads (a manifest or one glTF level) in flight at once; beyond
// the load radius, the proxies' screen-space error limit (ProxyStreamer).
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

        /// <summary>Why these settings cannot be used, or null.</summary>
        public string Problem()
        {
            if (!(LoadRadius > 0) || double.IsInfinity(LoadRadius)) return "load radius must be a positive number, found " + LoadRadius;
            if (!(UnloadRadius >= LoadRadius) || double.IsInfinity(UnloadRadius))
                return "unload radius (" + UnloadRadius + ") must be at least the load radius (" + LoadRadius + ")";
            if (!(MaximumScreenSpaceError > 0) || double.IsInfinity(MaximumScreenSpaceError))
                return "maximum screen-space error must be a positive number of pixels, found " + MaximumScreenSpaceError;
            if (MaxConcurrentLoads < 1) return "at least one concurrent load is needed, found " + MaxConcurrentLoads;
            return null;
        }
    }
}
