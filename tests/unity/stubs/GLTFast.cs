// Stand-in for glTFast (com.unity.cloud.gltfast 6.x, assembly "glTFast"): exactly the members
// unity_package uses, with glTFast's namespaces and signatures. In glTFast 6 GltfImport derives
// from GltfImportBase<Root>, which derives from GltfImportBase; the generic middle class is left
// out here because callers never name it. Load records the settings it is given and reports
// failure (the C# tests read them); the other bodies throw or do nothing: loading needs the Unity
// runtime. Checked against the release/6.3.0 tag and the newest main of
// Unity-Technologies/com.unity.cloud.gltfast.
using System;
using System.Collections.Generic;
using System.Threading;
using System.Threading.Tasks;
using UnityEngine;

[assembly: System.Runtime.CompilerServices.InternalsVisibleTo("VWorldLod.Tests")]

namespace GLTFast.Loading { public interface IDownloadProvider { } }
namespace GLTFast.Materials { public interface IMaterialGenerator { } }
namespace GLTFast.Logging
{
    public interface ICodeLogger { }

    public class CollectingLogger : ICodeLogger
    {
        public IEnumerable<LogItem> Items { get { return new LogItem[0]; } }
    }

    public class LogItem
    {
        public LogType Type { get { throw new NotSupportedException("stand-in"); } }
    }
}

namespace GLTFast
{
    using GLTFast.Loading;
    using GLTFast.Logging;
    using GLTFast.Materials;

    public interface IDeferAgent { }

    // Real: a [Serializable] class whose properties wrap private serialized fields.
    public class ImportSettings
    {
        public bool GenerateMipMaps { get; set; }
    }

    public abstract class GltfImportBase : IDisposable
    {
        internal static readonly List<ImportSettings> loadedWith = new List<ImportSettings>();
        internal static int disposed;
        internal static readonly List<byte[]> loadedBytes = new List<byte[]>();

        public Task<bool> Load(Uri url, ImportSettings importSettings = null, CancellationToken cancellationToken = default(CancellationToken))
        {
            loadedWith.Add(importSettings);
            return Task.FromResult(false);
        }

        public Task<bool> Load(byte[] data, Uri uri = null, ImportSettings importSettings = null, CancellationToken cancellationToken = default(CancellationToken))
        {
            loadedWith.Add(importSettings);
            loadedBytes.Add(data);
            return Task.FromResult(false);
        }

        public Task<bool> InstantiateMainSceneAsync(Transform parent, CancellationToken cancellationToken = default(CancellationToken))
        {
            throw new NotSupportedException("stand-in");
        }

        public void Dispose() { disposed++; }
    }

    public class GltfImport : GltfImportBase
    {
        public GltfImport(IDownloadProvider downloadProvider = null, IDeferAgent deferAgent = null,
                          IMaterialGenerator materialGenerator = null, ICodeLogger logger = null) { }
    }
}
