// Stand-in for glTFast (com.unity.cloud.gltfast 6.x, assembly "glTFast"): exactly the members
// unity_package uses, with glTFast's namespaces and signatures. In glTFast 6 GltfImport derives
// from GltfImportBase<Root>, which derives from GltfImportBase; the generic middle class is left
// out here because callers never name it. Bodies throw: loading needs the Unity runtime.
using System;
using System.Collections.Generic;
using System.Threading;
using System.Threading.Tasks;
using UnityEngine;

namespace GLTFast.Loading { public interface IDownloadProvider { } }
namespace GLTFast.Materials { public interface IMaterialGenerator { } }
namespace GLTFast.Logging
{
    public interface ICodeLogger { }

    public class CollectingLogger : ICodeLogger
    {
        public IEnumerable<LogItem> Items { get { throw new NotSupportedException("stand-in"); } }
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

    public class ImportSettings { }

    public abstract class GltfImportBase : IDisposable
    {
        public Task<bool> Load(Uri url, ImportSettings importSettings = null, CancellationToken cancellationToken = default(CancellationToken))
        {
            throw new NotSupportedException("stand-in");
        }

        public Task<bool> InstantiateMainSceneAsync(Transform parent, CancellationToken cancellationToken = default(CancellationToken))
        {
            throw new NotSupportedException("stand-in");
        }

        public void Dispose() { throw new NotSupportedException("stand-in"); }
    }

    public class GltfImport : GltfImportBase
    {
        public GltfImport(IDownloadProvider downloadProvider = null, IDeferAgent deferAgent = null,
                          IMaterialGenerator materialGenerator = null, ICodeLogger logger = null) { }
    }
}
