// The one error type of the package's plain logic: names the manifest, the field and the problem.
using System;

namespace VWorldLod
{
    /// <summary>
    /// A manifest (or one building in it) that cannot be used. Message:
    /// "&lt;manifest path&gt;: &lt;field&gt;: &lt;problem&gt;", e.g.
    /// "Assets/T/lod_manifest.json: buildings[2] (id B3).lods[1].file: B3/lod1.glb does not exist".
    /// </summary>
    public class ManifestException : Exception
    {
        public readonly string ManifestPath;
        public readonly string Field;
        public readonly string Problem;

        public ManifestException(string manifestPath, string field, string problem, Exception inner = null)
            : base(manifestPath + ": " + (string.IsNullOrEmpty(field) ? "" : field + ": ") + problem, inner)
        {
            ManifestPath = manifestPath;
            Field = field;
            Problem = problem;
        }
    }
}
