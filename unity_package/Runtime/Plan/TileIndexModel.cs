// The export's tile index (OUT/tiles.json, written by exporter/tile_index.py; schema
// exporter/schema/tile_index.schema.json) as [Serializable] classes with public fields, filled by
// Unity's JsonUtility or PlainJsonManifestParser.ParseAs alike. Unknown keys are ignored.
//
// Frames: bounds and center in degrees (lon/lat) and metres (elev); manifest paths relative to the
// index's folder (or base URL), '/' separated.
using System;

namespace VWorldLod
{
    [Serializable]
    public class TileIndex
    {
        public string format;
        public string version;
        public TileIndexEntry[] tiles;
    }

    [Serializable]
    public class TileIndexEntry
    {
        /// <summary>"&lt;level&gt;_&lt;idx&gt;_&lt;idy&gt;", the tile's folder.</summary>
        public string name;
        public int level;
        public long idx;
        public long idy;
        public TileBounds bounds;
        public GeoCenter center;
        /// <summary>The tile's lod_manifest.json relative to the index, e.g. "15_279418_116113/lod_manifest.json".</summary>
        public string manifest;
        /// <summary>Buildings in the tile's manifest.</summary>
        public int buildings;
        /// <summary>The manifest's radii (earth_radius_m: R, metres; unity_radius: UR, Unity units).</summary>
        public GlobeInfo globe;

        /// <summary>
        /// (3,) the tile centre in the scene, Unity units: relative to origin (East/Up/North), or
        /// with origin null on the paper's globe (equations (1)-(2)).
        /// </summary>
        public double[] ScenePosition(GeoOrigin origin)
        {
            if (origin != null) return origin.ScenePosition(center.lon, center.lat, center.elev, globe.earth_radius_m, globe.unity_radius);
            return Placement.GlobePosition(center.lon, center.lat, center.elev, globe.earth_radius_m, globe.unity_radius);
        }
    }
}
