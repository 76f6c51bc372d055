// From a validated manifest to what Unity has to build: per building, its LoD files (paths
// relative to the manifest's folder joined to it), the LODGroup's screen-relative heights and
// fade settings, and where the building goes. Pure data, no Unity types; the Editor importer and
// the runtime loader both build from a TilePlan.
//
// Placement (docs/ARCHITECTURE.md, "Placement dicts"):
//   tile_relative: a tile root at tile.placement (Unity globe frame, scale UR/R) and each building
//                  under it at relative_placement (tile East/Up/North, metres, scale 1);
//   globe:         no tile root transform (identity); each building at its placement (Unity globe frame).
// Either way Compose(TileRoot, building.Local) is the building's globe placement.
// In a scene (Editor prefabs, runtime streaming) both modes are placed the same way: the tile
// root at RootPose(origin) -- relative to the scene's georeference (GeoOrigin), or with no origin
// at tile.placement on the paper's globe -- and each building under it at its relative_placement
// (Relative), so under a georeference Transforms only hold small numbers.
using System;
using System.Collections.Generic;
using System.IO;
using System.Security.Cryptography;
using System.Text;
using System.Text.RegularExpressions;

namespace VWorldLod
{
    public enum PlacementMode { TileRelative, Globe }

    /// <summary>Mirrors UnityEngine.LODFadeMode (same order and values).</summary>
    public enum LodFadeKind { None = 0, CrossFade = 1, SpeedTree = 2 }

    /// <summary>One LoD of one building.</summary>
    public class LevelPlan
    {
        public int Level;
        /// <summary>As written in the manifest: relative to its folder.</summary>
        public string File;
        /// <summary>Manifest folder + File, '/' separated (an asset path inside Unity).</summary>
        public string Path;
        /// <summary>LOD.screenRelativeTransitionHeight: this level shows above it (0..1 of the screen height).</summary>
        public double ScreenRelativeHeight;
        /// <summary>LOD.fadeTransitionWidth (0..1), used with cross-fading.</summary>
        public double FadeTransitionWidth;
        /// <summary>Pixels: the level's largest atlas (texture_size); 0 x 0 when untextured.</summary>
        public int TextureWidth, TextureHeight;
        /// <summary>
        /// Metres: how far the level may be from LOD0 (geometry and texture): the manifest's
        /// error_m, or quality.hausdorff_rel x LOD0's bounding-box diagonal for manifests without
        /// it; 0 for LOD0; NaN when neither is known.
        /// </summary>
        public double ErrorM;
    }

    /// <summary>One building's LODGroup.</summary>
    public class BuildingPlan
    {
        public string Id;
        /// <summary>Id made safe for a GameObject, prefab or file name.</summary>
        public string Name;
        public LevelPlan[] Levels;
        /// <summary>The building's transform under the tile root in the manifest's mode (see file header).</summary>
        public Placement Local;
        /// <summary>relative_placement: the building in the tile's East/Up/North frame (metres).</summary>
        public Placement Relative;
        /// <summary>Warnings the exporter recorded for this building.</summary>
        public string[] Problems;
        /// <summary>
        /// Metres: LODGroup.size as Unity computes it (the largest side of LOD0's bounds, from the
        /// manifest's gltf_bounds); NaN when the manifest has no bounds (before 0.4.2).
        /// </summary>
        public double Size = double.NaN;
        /// <summary>(3,) LOD0's bounds centre in the building's Unity frame (glTF's +X West flipped to East), metres.</summary>
        public double[] Center = new double[3];
        /// <summary>The file it was read from (manifest source).</summary>
        public string Source;
        /// <summary>Its source attributes (AttributeReader.Attach; empty until then).</summary>
        public BuildingAttribute[] Attributes = new BuildingAttribute[0];
    }

    /// <summary>What one tile manifest asks Unity to build.</summary>
    public class TilePlan
    {
        public string ManifestPath;
        /// <summary>Folder holding the manifest, '/' separated ("" for the working folder).</summary>
        public string Folder;
        public string TileName;
        public PlacementMode Mode;
        /// <summary>The tile root's transform in the Unity globe frame (identity in globe mode).</summary>
        public Placement TileRoot;
        /// <summary>tile.placement: the tile centre's East/Up/North frame on the globe (either mode).</summary>
        public Placement GlobeRoot;
        /// <summary>tile.center: lon/lat in degrees, elev in metres.</summary>
        public double CenterLon, CenterLat, CenterElev;
        /// <summary>globe.earth_radius_m (R, metres) and globe.unity_radius (UR, Unity units).</summary>
        public double EarthRadius, UnityRadius;
        public LodFadeKind FadeMode;
        public bool AnimateCrossFading;
        public BuildingPlan[] Buildings;
        /// <summary>Buildings that cannot be built, one error each (naming manifest, building and field).</summary>
        public ManifestException[] Failures;

        /// <summary>
        /// The tile root's pose with buildings at Relative under it: relative to the scene's
        /// georeference (East/Up/North at origin, Unity units), or with origin null the paper's
        /// absolute globe placement (tile.placement).
        /// </summary>
        public Placement RootPose(GeoOrigin origin)
        {
            return origin == null ? GlobeRoot : origin.FramePose(CenterLon, CenterLat, CenterElev, EarthRadius, UnityRadius);
        }
    }

    public static class LodPlanner
    {
        /// <summary>
        /// Reads, validates and plans the manifest at manifestPath. Tile-level problems (unreadable
        /// file, bad JSON, wrong format/version, bad heights) throw ManifestException; a bad
        /// building goes to TilePlan.Failures and the others are still planned.
        /// </summary>
        public static TilePlan Load(string manifestPath, IManifestParser parser, Func<string, bool> fileExists)
        {
            string text;
            try
            {
                text = System.IO.File.ReadAllText(manifestPath, Encoding.UTF8);
            }
            catch (Exception e)
            {
                if (!(e is IOException || e is UnauthorizedAccessException || e is ArgumentException || e is NotSupportedException)) throw;
                throw new ManifestException(manifestPath, "", "cannot read the manifest: " + e.Message, e);
            }
            return AttributeReader.Attach(Plan(parser.Parse(text, manifestPath), manifestPath, fileExists), text);
        }

        /// <summary>Validates and plans an already parsed manifest (see Load).</summary>
        public static TilePlan Plan(TileManifest m, string manifestPath, Func<string, bool> fileExists)
        {
            ManifestValidator.ValidateTile(m, manifestPath);
            PlacementMode mode = ManifestValidator.ParsePlacementMode(m.globe.placement).Value;
            double[] heights = m.lod_group.screen_relative_heights;
            string folder = FolderOf(manifestPath);

            var plans = new List<BuildingPlan>();
            var failures = new List<ManifestException>();
            var seen = new HashSet<string>();
            BuildingEntry[] buildings = m.buildings ?? new BuildingEntry[0];
            for (int i = 0; i < buildings.Length; i++)
            {
                BuildingEntry b = buildings[i];
                ManifestException problem = ManifestValidator.BuildingProblem(b, i, heights.Length, mode, folder, fileExists, manifestPath);
                if (problem == null && !seen.Add(SafeName(b.id)))
                    problem = new ManifestException(manifestPath, "buildings[" + i + "] (id " + b.id + ").id", "another building already has this id (or the same safe name " + SafeName(b.id) + ")");
                if (problem != null)
                {
                    failures.Add(problem);
                    continue;
                }
                plans.Add(PlanBuilding(b, heights, m.lod_group.fade_transition_width, mode, folder));
            }

            return new TilePlan
            {
                ManifestPath = manifestPath,
                Folder = folder,
                TileName = m.tile.name,
                Mode = mode,
                TileRoot = mode == PlacementMode.TileRelative ? Placement.FromData(m.tile.placement) : Placement.Identity,
                GlobeRoot = Placement.FromData(m.tile.placement),
                CenterLon = m.tile.center.lon,
                CenterLat = m.tile.center.lat,
                CenterElev = m.tile.center.elev,
                EarthRadius = m.globe.earth_radius_m,
                UnityRadius = m.globe.unity_radius,
                FadeMode = ManifestValidator.ParseFadeMode(m.lod_group.fade_mode).Value,
                AnimateCrossFading = m.lod_group.animate_cross_fading,
                Buildings = plans.ToArray(),
                Failures = failures.ToArray(),
            };
        }

        static BuildingPlan PlanBuilding(BuildingEntry b, double[] heights, double fadeWidth, PlacementMode mode, string folder)
        {
            var levels = new LevelPlan[b.lods.Length];
            double[] errors = LevelErrors(b.lods);
            for (int k = 0; k < levels.Length; k++)
            {
                int[] texture = b.lods[k].texture_size;
                levels[k] = new LevelPlan
                {
                    Level = k,
                    File = b.lods[k].file,
                    Path = ManifestValidator.JoinPath(folder, b.lods[k].file),
                    ScreenRelativeHeight = LevelHeight(heights, k, levels.Length),
                    FadeTransitionWidth = fadeWidth,
                    TextureWidth = texture != null && texture.Length == 2 ? texture[0] : 0,
                    TextureHeight = texture != null && texture.Length == 2 ? texture[1] : 0,
                    ErrorM = errors[k],
                };
            }
            GltfBounds bounds = b.lods[0].gltf_bounds;
            bool hasBounds = bounds != null && bounds.low != null && bounds.high != null && bounds.low.Length == 3 && bounds.high.Length == 3;
            return new BuildingPlan
            {
                Size = hasBounds ? Math.Max(bounds.high[0] - bounds.low[0], Math.Max(bounds.high[1] - bounds.low[1], bounds.high[2] - bounds.low[2])) : double.NaN,
                Center = hasBounds
                    ? new[] { -(bounds.low[0] + bounds.high[0]) / 2, (bounds.low[1] + bounds.high[1]) / 2, (bounds.low[2] + bounds.high[2]) / 2 }
                    : new double[3],
                Id = b.id,
                Name = SafeName(b.id),
                Levels = levels,
                Local = Placement.FromData(mode == PlacementMode.TileRelative ? b.relative_placement : b.placement),
                Relative = Placement.FromData(b.relative_placement),
                Problems = b.problems ?? new string[0],
                Source = b.source,
            };
        }

        /// <summary>
        /// Metres, per level: the level's error from LOD0 (the manifest's per-level contract,
        /// docs/manifest.md). error_m (texture-aware, max of the certified geometric bound and the
        /// texture error) when the building's levels carry it (some level below LOD0 has
        /// error_m &gt; 0: JsonUtility cannot tell an absent number from 0); otherwise
        /// quality.hausdorff_rel x LOD0's bounding-box diagonal (gltf_bounds); NaN where neither is
        /// known. LOD0 is 0.
        /// </summary>
        public static double[] LevelErrors(LodEntry[] lods)
        {
            var errors = new double[lods.Length];
            bool texelAware = false;
            for (int k = 1; k < lods.Length; k++) texelAware |= lods[k].error_m > 0;
            GltfBounds bounds = lods.Length > 0 ? lods[0].gltf_bounds : null;
            double diagonal = double.NaN;
            if (bounds != null && bounds.low != null && bounds.high != null && bounds.low.Length == 3 && bounds.high.Length == 3)
            {
                double dx = bounds.high[0] - bounds.low[0], dy = bounds.high[1] - bounds.low[1], dz = bounds.high[2] - bounds.low[2];
                diagonal = Math.Sqrt(dx * dx + dy * dy + dz * dz);
            }
            for (int k = 1; k < lods.Length; k++)
            {
                if (texelAware) errors[k] = lods[k].error_m;
                else if (lods[k].quality != null) errors[k] = lods[k].quality.hausdorff_rel * diagonal;
                else errors[k] = double.NaN;
            }
            return errors;
        }

        /// <summary>
        /// Why the tile's LODGroups will not fade as its manifest asks, or null. glTFast's shaders
        /// (Built-in, and the Shader Graphs for URP and HDRP) are not compiled for LOD cross-fade
        /// (LOD_FADE_CROSSFADE is commented out in the Built-in ones; the graphs have
        /// supportLodCrossFade off), so with fade_mode cross_fade both levels draw in full during
        /// each transition instead of dithering between them.
        /// </summary>
        public static string FadeWarning(TilePlan tile)
        {
            if (tile.FadeMode != LodFadeKind.CrossFade) return null;
            return tile.ManifestPath + ": lod_group.fade_mode is cross_fade, but glTFast's shaders do not support LOD cross-fade: "
                   + "during each transition both levels draw in full. Export with unity.fade_mode: none, or give the buildings "
                   + "materials whose shaders support LOD cross-fade (LOD_FADE_CROSSFADE)";
        }

        /// <summary>
        /// Height of level k of a building with levelCount levels. A building with fewer levels than
        /// the tile keeps its last level until the tile's last height (where culling starts), so it
        /// disappears at the same screen size as the others.
        /// </summary>
        public static double LevelHeight(double[] heights, int k, int levelCount)
        {
            return k == levelCount - 1 ? heights[heights.Length - 1] : heights[k];
        }

        /// <summary>
        /// Screen-relative heights for a building of which only the levels in loaded (ascending,
        /// at least one) are there yet, e.g. while streaming coarsest first: each loaded level also
        /// covers the missing finer levels below it down to the next loaded one, the first one
        /// shows above its height (LODGroup's LOD0 has no upper bound) and the last one keeps the
        /// building's culling height. With every level loaded these are the plan's own heights.
        /// </summary>
        public static double[] LoadedHeights(BuildingPlan building, int[] loaded)
        {
            int n = building.Levels.Length;
            var heights = new double[loaded.Length];
            for (int i = 0; i < loaded.Length; i++)
                heights[i] = i == loaded.Length - 1
                    ? building.Levels[n - 1].ScreenRelativeHeight
                    : building.Levels[loaded[i + 1] - 1].ScreenRelativeHeight;
            return heights;
        }

        /// <summary>
        /// The exporter's file-system-safe name of a building id (exporter.names.safe_folder_name):
        /// runs of characters other than ASCII letters, digits, '.', '_' and '-' become '_', leading
        /// and trailing '.'/'_' go ("building" if nothing is left), and a changed, over-long (more
        /// than 80 characters) or reserved name (a Windows device name, or a tile folder's own file)
        /// gets the first 8 hex digits of the id's SHA-1 (after at most 80 characters) so distinct
        /// ids stay distinct.
        /// </summary>
        static readonly string[] TileFiles = { "lod_manifest.json", "report.html", "report", "tiles.json", "index.html" };

        public static string SafeName(string id)
        {
            string name = Regex.Replace(id, "[^0-9A-Za-z._-]+", "_").Trim('.', '_');
            if (name.Length == 0) name = "building";
            bool reserved = Regex.IsMatch(name, "^(con|prn|aux|nul|com[0-9]|lpt[0-9])(\\..*)?$", RegexOptions.IgnoreCase)
                || Array.IndexOf(TileFiles, name.ToLowerInvariant()) >= 0;
            if (name == id && name.Length <= 80 && !reserved) return name;
            using (SHA1 sha1 = SHA1.Create())
            {
                byte[] digest = sha1.ComputeHash(Encoding.UTF8.GetBytes(id));
                var hex = new StringBuilder();
                for (int k = 0; k < 4; k++) hex.Append(digest[k].ToString("x2"));
                return (name.Length > 80 ? name.Substring(0, 80) : name) + "_" + hex;
            }
        }

        static string FolderOf(string manifestPath)
        {
            string p = manifestPath.Replace('\\', '/');
            int slash = p.LastIndexOf('/');
            return slash < 0 ? "" : p.Substring(0, slash);
        }
    }
}
