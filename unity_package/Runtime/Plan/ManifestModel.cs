// The tile manifest (lod_manifest.json) as plain [Serializable] classes with public fields, so
// that Unity's JsonUtility.FromJson<TileManifest> and PlainJsonManifestParser fill them the same
// way. Field names are the JSON keys (snake_case) of exporter/schema/lod_manifest.schema.json,
// the source of truth; keys not declared here (the effective "config", summary statistics) are
// ignored, as JsonUtility ignores them.
//
// Frames: tile.placement and buildings[].placement are in the paper's Unity globe frame
// (left-handed, y up, Unity units); buildings[].relative_placement is in the tile's
// East/Up/North frame (metres). Angles in degrees, elevations and lengths in metres.
using System;

namespace VWorldLod
{
    [Serializable]
    public class TileManifest
    {
        public string format;
        public string version;
        public GeneratorInfo generator;
        public TileInfo tile;
        public GlobeInfo globe;
        public LodGroupSettings lod_group;
        public BuildingEntry[] buildings;
        public SkippedEntry[] skipped;
        public ManifestSummary summary;
    }

    [Serializable]
    public class GeneratorInfo
    {
        public string name;
        public string version;
    }

    [Serializable]
    public class TileInfo
    {
        public int level;
        public long idx;
        public long idy;
        public string name;
        public TileBounds bounds;
        public GeoCenter center;
        /// <summary>The tile root: Unity globe frame, scale UR/R.</summary>
        public PlacementData placement;
    }

    /// <summary>Tile bounds in degrees of longitude (west/east) and latitude (south/north).</summary>
    [Serializable]
    public class TileBounds
    {
        public double west;
        public double south;
        public double east;
        public double north;
    }

    /// <summary>lon/lat in degrees, elev in metres.</summary>
    [Serializable]
    public class GeoCenter
    {
        public double lon;
        public double lat;
        public double elev;
    }

    /// <summary>Unity's transform conventions: position [x, y, z], rotation quaternion [x, y, z, w], uniform scale.</summary>
    [Serializable]
    public class PlacementData
    {
        public double[] position;
        public double[] rotation;
        public double scale;
    }

    [Serializable]
    public class GlobeInfo
    {
        /// <summary>R, metres.</summary>
        public double earth_radius_m;
        /// <summary>UR, Unity units.</summary>
        public double unity_radius;
        public string handedness;
        public string up;
        /// <summary>"tile_relative" or "globe".</summary>
        public string placement;
    }

    [Serializable]
    public class LodGroupSettings
    {
        /// <summary>LOD0 first, strictly decreasing in (0, 1]; below the last one the building is culled.</summary>
        public double[] screen_relative_heights;
        /// <summary>"none", "cross_fade" or "speed_tree" (LODGroup.fadeMode).</summary>
        public string fade_mode;
        public bool animate_cross_fading;
        public double fade_transition_width;
        public int[] terrain_levels;
    }

    [Serializable]
    public class BuildingEntry
    {
        public string id;
        /// <summary>Folder of the building's glTF files, relative to the manifest (optional).</summary>
        public string folder;
        public string source;
        public string input_hash;
        public GeoCenter center;
        /// <summary>Unity globe frame, scale UR/R.</summary>
        public PlacementData placement;
        /// <summary>Tile East/Up/North frame, metres, scale 1.</summary>
        public PlacementData relative_placement;
        public LodEntry[] lods;
        public string[] problems;
    }

    [Serializable]
    public class LodEntry
    {
        public int level;
        /// <summary>glTF-binary path relative to the manifest's folder, '/' separated.</summary>
        public string file;
        public int triangles;
        public int vertices;
        /// <summary>[width, height] in pixels; [0, 0] when untextured.</summary>
        public int[] texture_size;
        public long texture_bytes;
        public long file_bytes;
        /// <summary>The file's position bounds in its glTF frame (+X West, +Y Up, +Z North, metres); absent before 0.4.2.</summary>
        public GltfBounds gltf_bounds;
        /// <summary>
        /// Metres: the level's error, max(certified geometric bound, texture error); 0 for LOD0 and
        /// when absent (before the texture-aware error): consumers then fall back to
        /// quality.hausdorff_rel x LOD0's bounding-box diagonal (LodPlanner.LevelErrors).
        /// </summary>
        public double error_m;
        /// <summary>Metres the level may deviate from LOD0 (its screen error budget); 0 when absent (LOD0, no budget).</summary>
        public double error_budget_m;
        /// <summary>True when the level has no fewer triangles than the level above (its budget allowed no collapse).</summary>
        public bool no_smaller_than_above;
        public LodQuality quality;
    }

    [Serializable]
    public class LodQuality
    {
        public double triangle_ratio;
        public double hausdorff_rel;
        public double silhouette_iou;
        public double wall_coverage;
        public double boundary_length_change;
        public double new_holes;
        /// <summary>Metres per texel of the level's atlas on the surface; 0 when absent or untextured.</summary>
        public double texel_m;
    }

    /// <summary>Position bounds (glTF frame, metres): low and high corners, [x, y, z] each.</summary>
    [Serializable]
    public class GltfBounds
    {
        public double[] low;
        public double[] high;
    }

    [Serializable]
    public class SkippedEntry
    {
        public string source;
        public string reason;
        public string id;
    }

    [Serializable]
    public class ManifestSummary
    {
        public int buildings;
        public int skipped;
        public SummaryLevel[] levels;
    }

    [Serializable]
    public class SummaryLevel
    {
        public int level;
        public double mean_triangles;
        public double ratio_to_lod0;
        public long total_triangles;
        public double mean_texture_pixels;
    }
}
