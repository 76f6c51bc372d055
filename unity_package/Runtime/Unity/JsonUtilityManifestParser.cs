// The manifest parser inside Unity: JsonUtility on the same classes PlainJsonManifestParser fills.
using System;
using UnityEngine;

namespace VWorldLod
{
    public class JsonUtilityManifestParser : IManifestParser
    {
        public TileManifest Parse(string json, string manifestPath)
        {
            TileManifest manifest;
            try
            {
                manifest = JsonUtility.FromJson<TileManifest>(json);
            }
            catch (ArgumentException e)
            {
                // JsonUtility reports malformed JSON as ArgumentException.
                throw new ManifestException(manifestPath, "", "not valid JSON: " + e.Message, e);
            }
            if (manifest == null)
                throw new ManifestException(manifestPath, "", "empty or not a JSON object");
            return manifest;
        }
    }
}
