// Where the streamer reads from: the tile index's URL from the component's setting, and the
// URLs of the files it names. Works for StreamingAssets on every platform (a plain folder on
// desktop, "jar:file://...!/assets" on Android, an http(s) URL on WebGL), for absolute folders
// and for http(s) base URLs. Manifests and glTF files are then addressed relative to the index.
// A URL's query and fragment (a signed URL's "?sig=...") stay on every URL made from it: the
// tile index's, the manifests', the proxies' and the levels' .glb files.
using System;
using System.IO;

namespace VWorldLod
{
    public static class StreamingPaths
    {
        /// <summary>
        /// The URL of the file named by setting: an http(s)/file/jar URL as it is; an absolute path
        /// as a file:// URL; anything else relative to streamingAssets (Application.streamingAssetsPath).
        /// A setting that does not end in ".json" names a folder and gets defaultFile appended.
        /// </summary>
        public static string Resolve(string setting, string streamingAssets, string defaultFile)
        {
            string s = (setting ?? "").Trim();
            if (s.Length == 0) s = defaultFile;
            string query = IsUrl(s) ? Query(s) : "";
            s = s.Substring(0, s.Length - query.Length);
            if (!s.EndsWith(".json", StringComparison.OrdinalIgnoreCase))
                s = s.TrimEnd('/', '\\') + "/" + defaultFile;
            if (IsUrl(s)) return s + query;
            if (Path.IsPathRooted(s)) return new Uri(Path.GetFullPath(s)).AbsoluteUri;
            string root = (streamingAssets ?? "").Replace('\\', '/').TrimEnd('/');
            string relative = s.Replace('\\', '/').TrimStart('/');
            if (IsUrl(root)) return root + "/" + relative;
            return new Uri(Path.GetFullPath(Path.Combine(root, relative))).AbsoluteUri;
        }

        /// <summary>The URL of relative (a '/' separated path from the index or a manifest) next to url.</summary>
        public static string Beside(string url, string relative)
        {
            string query = Query(url);
            string path = url.Substring(0, url.Length - query.Length);
            int slash = path.LastIndexOf('/');
            string folder = slash < 0 ? "" : path.Substring(0, slash + 1);
            return folder + relative.Replace('\\', '/').TrimStart('/') + query;
        }

        /// <summary>The query and fragment of a URL ("?sig=abc", "#x"), "" when it has none.</summary>
        public static string Query(string url)
        {
            if (!IsUrl(url)) return "";
            int at = url.IndexOfAny(QueryStart);
            return at < 0 ? "" : url.Substring(at);
        }

        static readonly char[] QueryStart = { '?', '#' };

        /// <summary>
        /// The plan of a manifest read from url: its levels' paths are URLs beside it, carrying
        /// url's query (LodPlanner.Plan over url without it, which names the manifest in errors).
        /// </summary>
        public static TilePlan PlanAt(TileManifest manifest, string url)
        {
            string query = Query(url);
            TilePlan plan = LodPlanner.Plan(manifest, url.Substring(0, url.Length - query.Length), path => true);
            if (query.Length == 0) return plan;
            foreach (BuildingPlan b in plan.Buildings)
                foreach (LevelPlan level in b.Levels) level.Path += query;
            return plan;
        }

        /// <summary>Whether s starts with a URL scheme the streamer reads (http, https, file, jar).</summary>
        public static bool IsUrl(string s)
        {
            string lower = s.ToLowerInvariant();
            return lower.StartsWith("http://") || lower.StartsWith("https://") || lower.StartsWith("file://") || lower.StartsWith("jar:");
        }
    }
}
