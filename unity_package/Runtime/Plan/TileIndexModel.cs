// The export's tile index (OUT/tiles.json, written by exporter/tile_index.py; schema
// exporter/schema/tile_index.schema.json) as [Serializable] classes with public fields, filled by
// Unity's JsonUtility or PlainJsonManifestParser.ParseAs alike. Unknown keys are ignored.
//
// Frames: bounds and center in degrees (lon/lat) and metres (elev); manifest and proxy file paths
// relative to the index's folder (or base URL), '/' separated. A proxy's .glb is in its tile's
// glTF frame (+X West, +Y Up, +Z North, metres) at center, elevation 0: placed like a tile root.
using System;

namespace VWorldLod
{
    [Serializable]
    public class TileIndex
    {
        public string format;
        public string version;
        public TileIndexEntry[] tiles;
        /// <summary>The tileset's HLOD proxies (version 1.1; absent without a tileset).</summary>
        public ProxyEntry[] proxies;
    }

    /// <summary>A quadtree tile of the index: where it is and on which globe (tiles and proxies alike).</summary>
    [Serializable]
    public class IndexedTile
    {
        /// <summary>"&lt;level&gt;_&lt;idx&gt;_&lt;idy&gt;": the tile's folder, or the quadtree tile a proxy stands for.</summary>
        public string name;
        public int level;
        public long idx;
        public long idy;
        public TileBounds bounds;
        /// <summary>The tile centre, elevation 0 (a tile root's and a proxy's glTF frame origin).</summary>
        public GeoCenter center;
        /// <summary>The radii (earth_radius_m: R, metres; unity_radius: UR, Unity units).</summary>
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

    [Serializable]
    public class ProxyEntry : IndexedTile
    {
        /// <summary>Its .glb relative to the index, e.g. "tileset_proxies/14_139709_58056.glb".</summary>
        public string file;
        /// <summary>Its frame's Unity-globe placement (Unity units), as a manifest's tile.placement.</summary>
        public PlacementData placement;
        /// <summary>Metres: a sphere about center holding the proxy.</summary>
        public double radius_m;
        /// <summary>Metres: tileset.json's geometricError (certified against the LOD0 below it).</summary>
        public double geometric_error;
        /// <summary>Metres per texel of the proxy's atlas on its surface (0: not stated, before 0.5.0).</summary>
        public double texel_m;
        /// <summary>Pixels per side of the proxy's (square) atlas (0: not stated, before 0.6.0, when every proxy's was the export's proxy_atlas_size).</summary>
        public int atlas_px;
        /// <summary>Names of the child proxies (finer, together covering this one's tiles below them).</summary>
        public string[] children;
        /// <summary>Names of the building tiles directly under it (tiles.json's names).</summary>
        public string[] tiles;

        /// <summary>The pose of the proxy's frame relative to origin, or on the globe (its placement) when origin is null.</summary>
        public Placement ScenePose(GeoOrigin origin)
        {
            if (origin != null) return origin.FramePose(center.lon, center.lat, center.elev, globe.earth_radius_m, globe.unity_radius);
            return Placement.FromData(placement);
        }
    }

    [Serializable]
    public class TileIndexEntry : IndexedTile
    {
        /// <summary>The tile's lod_manifest.json relative to the index, e.g. "15_279418_116113/lod_manifest.json".</summary>
        public string manifest;
        /// <summary>Buildings in the tile's manifest.</summary>
        public int buildings;
    }
}
