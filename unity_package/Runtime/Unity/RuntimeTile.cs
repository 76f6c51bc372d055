// What the streamer and the single-tile loader share at run time: a manifest read from a URL and
// planned (its bad buildings reported), and a tile root placed by VWorldLodTilePlacement.
using System;
using System.Threading;
using System.Threading.Tasks;
using UnityEngine;

namespace VWorldLod
{
    public static class RuntimeTile
    {
        /// <summary>
        /// The plan of the manifest at url (levels addressed beside it), or null when cancelled.
        /// Throws ManifestException or IOException naming url; bad buildings are logged.
        /// </summary>
        public static async Task<TilePlan> LoadPlanAsync(string url, CancellationToken cancellation)
        {
            string text = await WebText.GetAsync(url, cancellation);
            if (text == null || cancellation.IsCancellationRequested) return null;
            TilePlan plan = StreamingPaths.PlanAt(new JsonUtilityManifestParser().Parse(text, url), url);
            AttributeReader.Attach(plan, text);
            foreach (ManifestException failure in plan.Failures) Debug.LogError("VWorld LoD: " + failure.Message);
            return plan;
        }

        /// <summary>An empty tile root under parent, placed relative to the scene's georeference.</summary>
        public static GameObject CreateRoot(TilePlan plan, Transform parent)
        {
            var root = new GameObject(plan.TileName);
            root.transform.SetParent(parent, false);
            root.AddComponent<VWorldLodTilePlacement>().Configure(plan);
            root.GetComponent<VWorldLodTilePlacement>().Place();
            return root;
        }

        /// <summary>A console line for e, naming url unless e's message already does.</summary>
        public static string Describe(Exception e, string url)
        {
            return "VWorld LoD: " + (e is ManifestException || e.Message.StartsWith(url) ? e.Message : url + ": " + e.Message);
        }
    }
}
