// Reading and checking tiles.json: the index as a whole must be usable (else one
// ManifestException naming the file), each tile entry is checked on its own so a bad entry is
// reported and the other tiles still stream.
using System;
using System.Collections.Generic;

namespace VWorldLod
{
    public static class TileIndexReader
    {
        public const string Format = "vworld-lod-tile-index";
        public const string FileName = "tiles.json";
        public const int SupportedMajorVersion = 1;

        /// <summary>
        /// The usable tiles of the index text read from indexPath; problems gets one message per
        /// tile entry left out. parse turns JSON into a TileIndex (JsonUtility inside Unity, which
        /// throws ArgumentException on bad JSON; PlainJsonManifestParser.ParseAs outside).
        /// Throws ManifestException (naming indexPath) when the index cannot be used at all.
        /// </summary>
        public static TileIndexEntry[] Read(string text, string indexPath, Func<string, TileIndex> parse, List<string> problems)
        {
            if (string.IsNullOrEmpty(text) || text.Trim().Length == 0)
                throw new ManifestException(indexPath, "", "the tile index is empty");
            TileIndex index;
            try
            {
                index = parse(text);
            }
            catch (ArgumentException e)
            {
                throw new ManifestException(indexPath, "", "not valid JSON: " + e.Message, e);
            }
            if (index == null)
                throw new ManifestException(indexPath, "", "empty or not a JSON object");
            if (index.format != Format)
                throw new ManifestException(indexPath, "format", "expected \"" + Format + "\", found " + (index.format == null ? "nothing" : "\"" + index.format + "\"") + " (is this a tiles.json written by vworld-lod export?)");
            if (ManifestValidator.MajorVersion(index.version) != SupportedMajorVersion)
                throw new ManifestException(indexPath, "version", "version \"" + index.version + "\" is not supported; this package reads " + SupportedMajorVersion + ".x");
            var usable = new List<TileIndexEntry>();
            var names = new HashSet<string>();
            TileIndexEntry[] tiles = index.tiles ?? new TileIndexEntry[0];
            for (int i = 0; i < tiles.Length; i++)
            {
                string problem = EntryProblem(tiles[i]);
                if (problem == null && !names.Add(tiles[i].name)) problem = "another tile has the same name";
                if (problem != null)
                {
                    string label = tiles[i] == null || string.IsNullOrEmpty(tiles[i].name) ? "" : " (" + tiles[i].name + ")";
                    problems.Add(new ManifestException(indexPath, "tiles[" + i + "]" + label, problem + "; tile left out").Message);
                    continue;
                }
                usable.Add(tiles[i]);
            }
            return usable.ToArray();
        }

        /// <summary>Why one tile entry cannot be streamed, or null.</summary>
        public static string EntryProblem(TileIndexEntry t)
        {
            if (t == null) return "missing";
            if (string.IsNullOrEmpty(t.name)) return "name missing";
            if (t.center == null || GeoOrigin.Problem(t.center.lon, t.center.lat, t.center.elev) != null)
                return "center is not a place on the globe";
            if (t.globe == null || !(t.globe.earth_radius_m > 0) || !(t.globe.unity_radius > 0)
                || double.IsInfinity(t.globe.earth_radius_m) || double.IsInfinity(t.globe.unity_radius))
                return "globe.earth_radius_m and globe.unity_radius must be positive numbers";
            string m = t.manifest;
            if (string.IsNullOrEmpty(m)) return "manifest missing";
            if (m.StartsWith("/") || m.StartsWith("\\") || m.Contains(":"))
                return "manifest \"" + m + "\" is not relative to the index";
            foreach (string part in m.Split('/', '\\'))
                if (part == "..") return "manifest \"" + m + "\" leaves the index's folder";
            return null;
        }
    }
}
