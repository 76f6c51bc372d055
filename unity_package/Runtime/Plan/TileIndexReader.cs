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
            ProxyEntry[] proxies;
            return Read(text, indexPath, parse, problems, out proxies);
        }

        /// <summary>
        /// As Read, also giving the usable proxies: an entry is left out (one message in problems)
        /// when it is malformed or a child proxy or building tile it names is not usable, since
        /// refining it would leave a hole.
        /// </summary>
        public static TileIndexEntry[] Read(string text, string indexPath, Func<string, TileIndex> parse, List<string> problems, out ProxyEntry[] proxies)
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
            proxies = UsableProxies(index.proxies ?? new ProxyEntry[0], names, indexPath, problems);
            return usable.ToArray();
        }

        static ProxyEntry[] UsableProxies(ProxyEntry[] all, HashSet<string> tileNames, string indexPath, List<string> problems)
        {
            var bad = new Dictionary<int, string>();
            var byName = new Dictionary<string, int>();
            for (int i = 0; i < all.Length; i++)
            {
                string problem = ProxyProblem(all[i]);
                if (problem == null && byName.ContainsKey(all[i].name)) problem = "another proxy has the same name";
                if (problem != null) bad[i] = problem;
                else byName[all[i].name] = i;
            }
            // A proxy whose child or tile is missing is left out, and so, in turn, its parents.
            for (bool changed = true; changed;)
            {
                changed = false;
                for (int i = 0; i < all.Length; i++)
                {
                    if (bad.ContainsKey(i)) continue;
                    string missing = null;
                    foreach (string c in all[i].children)
                        if (!byName.ContainsKey(c) || bad.ContainsKey(byName[c])) missing = "its child proxy " + c + " is not usable";
                    foreach (string t in all[i].tiles)
                        if (!tileNames.Contains(t)) missing = "its tile " + t + " is not in the index";
                    if (missing == null) continue;
                    bad[i] = missing;
                    changed = true;
                }
            }
            var usable = new List<ProxyEntry>();
            for (int i = 0; i < all.Length; i++)
            {
                string problem;
                if (!bad.TryGetValue(i, out problem)) { usable.Add(all[i]); continue; }
                string label = all[i] == null || string.IsNullOrEmpty(all[i].name) ? "" : " (" + all[i].name + ")";
                problems.Add(new ManifestException(indexPath, "proxies[" + i + "]" + label, problem + "; proxy left out").Message);
            }
            return usable.ToArray();
        }

        /// <summary>Why one proxy entry cannot be shown, or null (missing children/tiles lists become empty).</summary>
        public static string ProxyProblem(ProxyEntry p)
        {
            if (p == null) return "missing";
            if (string.IsNullOrEmpty(p.name)) return "name missing";
            if (p.center == null || GeoOrigin.Problem(p.center.lon, p.center.lat, p.center.elev) != null)
                return "center is not a place on the globe";
            string globe = GlobeProblem(p.globe);
            if (globe != null) return globe;
            string file = PathProblem("file", p.file);
            if (file != null) return file;
            if (p.placement == null || p.placement.position == null || p.placement.position.Length != 3
                || p.placement.rotation == null || p.placement.rotation.Length != 4 || !(p.placement.scale > 0))
                return "placement needs position [x, y, z], rotation [x, y, z, w] and a positive scale";
            if (!(p.geometric_error >= 0) || double.IsInfinity(p.geometric_error)) return "geometric_error must be a number of metres >= 0";
            if (!(p.radius_m >= 0) || double.IsInfinity(p.radius_m)) return "radius_m must be a number of metres >= 0";
            if (p.children == null) p.children = new string[0];
            if (p.tiles == null) p.tiles = new string[0];
            if (p.children.Length + p.tiles.Length == 0) return "it stands for no tile (children and tiles empty)";
            return null;
        }

        static string GlobeProblem(GlobeInfo g)
        {
            if (g == null || !(g.earth_radius_m > 0) || !(g.unity_radius > 0)
                || double.IsInfinity(g.earth_radius_m) || double.IsInfinity(g.unity_radius))
                return "globe.earth_radius_m and globe.unity_radius must be positive numbers";
            return null;
        }

        static string PathProblem(string field, string m)
        {
            if (string.IsNullOrEmpty(m)) return field + " missing";
            if (m.StartsWith("/") || m.StartsWith("\\") || m.Contains(":"))
                return field + " \"" + m + "\" is not relative to the index";
            foreach (string part in m.Split('/', '\\'))
                if (part == "..") return field + " \"" + m + "\" leaves the index's folder";
            return null;
        }

        /// <summary>Why one tile entry cannot be streamed, or null.</summary>
        public static string EntryProblem(TileIndexEntry t)
        {
            if (t == null) return "missing";
            if (string.IsNullOrEmpty(t.name)) return "name missing";
            if (t.center == null || GeoOrigin.Problem(t.center.lon, t.center.lat, t.center.elev) != null)
                return "center is not a place on the globe";
            return GlobeProblem(t.globe) ?? PathProblem("manifest", t.manifest);
        }
    }
}
