// Loads one level's glTF with glTFast at run time, the way the streamer and the tile loader need:
// glTFast's messages go to Unity's console with the file named; cancellation (a tile unloaded, the
// component destroyed) never throws and leaves nothing behind; an import is only disposed once
// its own load has finished (disposing one in flight makes glTFast throw). Textures get mipmaps as
// in glTFast's Editor importer (LevelImportSettings).
//
// The .glb is downloaded here (WebText.GetBytesAsync, aborted when cancelled: glTFast's
// Load(Uri) keeps downloading after a cancellation) and handed to glTFast as bytes.
//
// glTFast's API used (present with these signatures from 6.3.0 on; see the package docs):
//   new GltfImport(IDownloadProvider, IDeferAgent, IMaterialGenerator, ICodeLogger)
//   Task<bool> Load(byte[], Uri, ImportSettings, CancellationToken); ImportSettings.GenerateMipMaps
//   Task<bool> InstantiateMainSceneAsync(Transform, CancellationToken)
//   CollectingLogger.Items / LogItem.Type (a logger of our own would have to follow ICodeLogger,
//   which gained a member in 6.4 that has a default implementation only from 6.10).
using System;
using System.Threading;
using System.Threading.Tasks;
using GLTFast;
using GLTFast.Logging;
using UnityEngine;

namespace VWorldLod
{
    public static class GltfLevelLoader
    {
        /// <summary>
        /// glTFast's settings for a level: textures with a mip chain. glTFast builds one only when
        /// GenerateMipMaps is set (false by default; its Editor importer sets it), and the
        /// exporter's samplers ask for trilinear filtering (LINEAR_MIPMAP_LINEAR): without mipmaps
        /// streamed buildings alias at a distance and differ from the Editor prefabs.
        /// </summary>
        public static ImportSettings LevelImportSettings()
        {
            return new ImportSettings { GenerateMipMaps = true };
        }

        /// <summary>
        /// The level at url instantiated under parent as an inactive GameObject named objectName,
        /// or null when it could not be loaded (reported in the console, naming url) or the load
        /// was cancelled (not reported).
        /// </summary>
        public static async Task<LoadedLevel> LoadAsync(string url, Transform parent, string objectName, CancellationToken cancellation)
        {
            byte[] data;
            try
            {
                data = await WebText.GetBytesAsync(url, cancellation);
            }
            catch (Exception e)
            {
                if (!cancellation.IsCancellationRequested) Debug.LogError("VWorld LoD: " + e.Message);
                return null;
            }
            if (data == null || cancellation.IsCancellationRequested) return null; // cancelled: the download was aborted
            return await LoadBytesAsync(data, url, parent, objectName, cancellation);
        }

        /// <summary>LoadAsync once the file's bytes are here (url names it and resolves relative URIs).</summary>
        public static async Task<LoadedLevel> LoadBytesAsync(byte[] data, string url, Transform parent, string objectName, CancellationToken cancellation)
        {
            var level = new GameObject(objectName);
            level.SetActive(false);
            level.transform.SetParent(parent, false);
            var logger = new CollectingLogger();
            var gltf = new GltfImport(null, null, null, logger);
            bool ok = false;
            Exception error = null;
            try
            {
                ok = await gltf.Load(data, new Uri(url), LevelImportSettings(), cancellation)
                     && !cancellation.IsCancellationRequested
                     && await gltf.InstantiateMainSceneAsync(level.transform, cancellation);
            }
            catch (Exception e)
            {
                error = e;
            }
            bool cancelled = cancellation.IsCancellationRequested;
            if (!cancelled) LogMessages(url, logger);
            if (ok && !cancelled && level != null) return new LoadedLevel(level, gltf);
            if (level != null) UnityEngine.Object.Destroy(level);
            gltf.Dispose();
            if (!cancelled)
                Debug.LogError("VWorld LoD: " + url + ": glTFast could not load it" + (error != null ? ": " + error.Message : " (glTFast's reasons are logged above)"));
            return null;
        }

        // glTFast's errors and warnings, each naming the file (its info messages are left out).
        static void LogMessages(string url, CollectingLogger logger)
        {
            if (logger.Items == null) return;
            foreach (LogItem item in logger.Items)
            {
                string text = "VWorld LoD: " + url + ": glTFast: " + item;
                if (item.Type == LogType.Warning) Debug.LogWarning(text);
                else if (item.Type != LogType.Log) Debug.LogError(text);
            }
        }
    }
}
