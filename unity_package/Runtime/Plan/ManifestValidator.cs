// Checks a parsed manifest before anything is built from it: the tile-level contract (format,
// version, LOD heights, placement mode, counts) and, separately, each building (its LoD files and
// placement), so that one bad building is reported and the rest of the tile still gets built.
// Rules follow exporter/schema/lod_manifest.schema.json and Unity's LODGroup: at most 8 levels,
// screen-relative heights strictly decreasing in (0, 1] (SetLODs ignores anything else).
using System;
using System.Collections.Generic;

namespace VWorldLod
{
    public static class ManifestValidator
    {
        public const string Format = "vworld-lod-manifest";
        public const int SupportedMajorVersion = 1;
        /// <summary>Unity's LODGroup limit.</summary>
        public const int MaxLevels = 8;
        /// <summary>How far |q| may be from 1 for a placement rotation (rounding in the JSON).</summary>
        public const double UnitQuaternionTolerance = 1e-5;

        /// <summary>Throws ManifestException on the first tile-level problem.</summary>
        public static void ValidateTile(TileManifest m, string manifestPath)
        {
            if (m.format != Format)
                throw new ManifestException(manifestPath, "format", "expected \"" + Format + "\", found " + Quote(m.format));
            if (MajorVersion(m.version) != SupportedMajorVersion)
                throw new ManifestException(manifestPath, "version", "version " + Quote(m.version) + " is not supported; this package reads " + SupportedMajorVersion + ".x");
            if (m.tile == null || string.IsNullOrEmpty(m.tile.name))
                throw new ManifestException(manifestPath, "tile.name", "missing");
            if (m.globe == null || ParsePlacementMode(m.globe.placement) == null)
                throw new ManifestException(manifestPath, "globe.placement", "expected \"tile_relative\" or \"globe\", found " + Quote(m.globe == null ? null : m.globe.placement));
            if (!(m.globe.earth_radius_m > 0) || !(m.globe.unity_radius > 0))
                throw new ManifestException(manifestPath, "globe", "earth_radius_m and unity_radius must be positive");
            ValidateHeights(m.lod_group == null ? null : m.lod_group.screen_relative_heights, manifestPath);
            if (ParseFadeMode(m.lod_group.fade_mode) == null)
                throw new ManifestException(manifestPath, "lod_group.fade_mode", "expected \"none\", \"cross_fade\" or \"speed_tree\", found " + Quote(m.lod_group.fade_mode));
            if (!(m.lod_group.fade_transition_width >= 0 && m.lod_group.fade_transition_width <= 1))
                throw new ManifestException(manifestPath, "lod_group.fade_transition_width", "must be in [0, 1], found " + m.lod_group.fade_transition_width);
            GeoCenter c = m.tile.center;
            if (c == null || GeoOrigin.Problem(c.lon, c.lat, c.elev) != null)
                throw new ManifestException(manifestPath, "tile.center", c == null ? "missing" : "lon " + c.lon + ", lat " + c.lat + ", elev " + c.elev + " is not a place on the globe");
            string placementProblem = PlacementProblem(m.tile.placement);
            if (placementProblem != null)
                throw new ManifestException(manifestPath, "tile.placement", placementProblem);
            int buildings = m.buildings == null ? 0 : m.buildings.Length;
            int skipped = m.skipped == null ? 0 : m.skipped.Length;
            if (m.summary == null || m.summary.buildings != buildings)
                throw new ManifestException(manifestPath, "summary.buildings", "says " + (m.summary == null ? 0 : m.summary.buildings) + " but the manifest lists " + buildings + " buildings");
            if (m.summary.skipped != skipped)
                throw new ManifestException(manifestPath, "summary.skipped", "says " + m.summary.skipped + " but the manifest lists " + skipped + " skipped sources");
        }

        /// <summary>LOD0 first: 1 to 8 heights, each in (0, 1], strictly decreasing.</summary>
        public static void ValidateHeights(double[] heights, string manifestPath)
        {
            const string field = "lod_group.screen_relative_heights";
            if (heights == null || heights.Length == 0)
                throw new ManifestException(manifestPath, field, "missing or empty");
            if (heights.Length > MaxLevels)
                throw new ManifestException(manifestPath, field, heights.Length + " levels; Unity's LODGroup takes at most " + MaxLevels);
            for (int k = 0; k < heights.Length; k++)
            {
                if (!(heights[k] > 0 && heights[k] <= 1))
                    throw new ManifestException(manifestPath, field + "[" + k + "]", heights[k] + " is not in (0, 1]");
                if (k > 0 && !(heights[k] < heights[k - 1]))
                    throw new ManifestException(manifestPath, field + "[" + k + "]", heights[k] + " is not below the previous level's " + heights[k - 1] + "; heights must strictly decrease from LOD0");
            }
        }

        /// <summary>
        /// The first problem of building index (as a ManifestException, not thrown), or null.
        /// fileExists receives each LoD's path joined to manifestFolder with '/'.
        /// </summary>
        public static ManifestException BuildingProblem(BuildingEntry b, int index, int levelCount, PlacementMode mode,
                                                        string manifestFolder, Func<string, bool> fileExists, string manifestPath)
        {
            string where = "buildings[" + index + "]";
            if (b == null || string.IsNullOrEmpty(b.id))
                return new ManifestException(manifestPath, where + ".id", "missing");
            where += " (id " + b.id + ")";
            if (b.lods == null || b.lods.Length == 0)
                return new ManifestException(manifestPath, where + ".lods", "no levels");
            if (b.lods.Length > levelCount)
                return new ManifestException(manifestPath, where + ".lods", b.lods.Length + " levels but lod_group.screen_relative_heights has " + levelCount);
            for (int k = 0; k < b.lods.Length; k++)
            {
                string lodField = where + ".lods[" + k + "]";
                LodEntry lod = b.lods[k];
                if (lod.level != k)
                    return new ManifestException(manifestPath, lodField + ".level", "expected " + k + " (levels in order from LOD0), found " + lod.level);
                string fileProblem = FileProblem(lod.file);
                if (fileProblem != null)
                    return new ManifestException(manifestPath, lodField + ".file", fileProblem);
                string path = JoinPath(manifestFolder, lod.file);
                if (!fileExists(path))
                    return new ManifestException(manifestPath, lodField + ".file", path + " does not exist");
            }
            // Both placements: the manifest's mode uses one, a georeferenced scene relative_placement.
            bool relativeFirst = mode == PlacementMode.TileRelative;
            for (int pass = 0; pass < 2; pass++)
            {
                bool relative = relativeFirst == (pass == 0);
                string placementProblem = PlacementProblem(relative ? b.relative_placement : b.placement);
                if (placementProblem != null)
                    return new ManifestException(manifestPath, where + "." + (relative ? "relative_placement" : "placement"), placementProblem);
            }
            return null;
        }

        /// <summary>Why a placement dict cannot be used, or null.</summary>
        public static string PlacementProblem(PlacementData p)
        {
            if (p == null) return "missing";
            if (p.position == null || p.position.Length != 3) return "position must have 3 numbers";
            if (p.rotation == null || p.rotation.Length != 4) return "rotation must have 4 numbers (x, y, z, w)";
            double norm2 = 0;
            foreach (double v in p.position) if (double.IsNaN(v) || double.IsInfinity(v)) return "position is not finite";
            foreach (double v in p.rotation) norm2 += v * v;
            if (!(Math.Abs(Math.Sqrt(norm2) - 1) <= UnitQuaternionTolerance)) return "rotation is not a unit quaternion (|q| = " + Math.Sqrt(norm2) + ")";
            if (!(p.scale > 0) || double.IsInfinity(p.scale)) return "scale must be a positive number, found " + p.scale;
            return null;
        }

        static string FileProblem(string file)
        {
            if (string.IsNullOrEmpty(file)) return "missing";
            if (file.StartsWith("/") || file.StartsWith("\\") || file.Contains(":"))
                return Quote(file) + " is not relative to the manifest's folder";
            foreach (string part in file.Split('/', '\\'))
                if (part == "..") return Quote(file) + " leaves the manifest's folder";
            string lower = file.ToLowerInvariant();
            if (!lower.EndsWith(".glb") && !lower.EndsWith(".gltf")) return Quote(file) + " is not a glTF file";
            return null;
        }

        /// <summary>folder + "/" + file with '/' separators (folder "" gives file).</summary>
        public static string JoinPath(string folder, string file)
        {
            file = file.Replace('\\', '/');
            if (string.IsNullOrEmpty(folder)) return file;
            return folder.Replace('\\', '/').TrimEnd('/') + "/" + file;
        }

        public static PlacementMode? ParsePlacementMode(string value)
        {
            if (value == "tile_relative") return PlacementMode.TileRelative;
            if (value == "globe") return PlacementMode.Globe;
            return null;
        }

        public static LodFadeKind? ParseFadeMode(string value)
        {
            if (value == "none") return LodFadeKind.None;
            if (value == "cross_fade") return LodFadeKind.CrossFade;
            if (value == "speed_tree") return LodFadeKind.SpeedTree;
            return null;
        }

        /// <summary>The number before the first '.' of a "major.minor" version, or -1.</summary>
        public static int MajorVersion(string version)
        {
            if (string.IsNullOrEmpty(version)) return -1;
            int dot = version.IndexOf('.');
            int major;
            return int.TryParse(dot < 0 ? version : version.Substring(0, dot), out major) ? major : -1;
        }

        static string Quote(string s)
        {
            return s == null ? "nothing" : "\"" + s + "\"";
        }
    }
}
