// Where the streamer reads from: the tile index's URL from the component's setting, and the
// URLs of the files it names. Works for StreamingAssets on every platform (a plain folder on
// desktop, "jar:file://...!/assets" on Android, an http(s) URL on WebGL), for absolute folders
// and for http(s) base URLs. Manifests and glTF files are then addressed relative to the index.
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
            if (!s.EndsWith(".json", StringComparison.OrdinalIgnoreCase))
                s = s.TrimEnd('/', '\\') + "/" + defaultFile;
            if (IsUrl(s)) return s;
            if (Path.IsPathRooted(s)) return new Uri(Path.GetFullPath(s)).AbsoluteUri;
            string root = (streamingAssets ?? "").Replace('\\', '/').TrimEnd('/');
            string relative = s.Replace('\\', '/').TrimStart('/');
            if (IsUrl(root)) return root + "/" + relative;
            return new Uri(Path.GetFullPath(Path.Combine(root, relative))).AbsoluteUri;
        }

        /// <summary>The URL of relative (a '/' separated path from the index or a manifest) next to url.</summary>
        public static string Beside(string url, string relative)
        {
            int slash = url.LastIndexOf('/');
            string folder = slash < 0 ? "" : url.Substring(0, slash + 1);
            return folder + relative.Replace('\\', '/').TrimStart('/');
        }

        /// <summary>Whether s starts with a URL scheme the streamer reads (http, https, file, jar).</summary>
        public static bool IsUrl(string s)
        {
            string lower = s.ToLowerInvariant();
            return lower.StartsWith("http://") || lower.StartsWith("https://") || lower.StartsWith("file://") || lower.StartsWith("jar:");
        }
    }
}
