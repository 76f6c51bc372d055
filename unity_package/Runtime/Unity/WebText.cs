// Reads a file from a URL with UnityWebRequest: a text (tile index, manifest) or bytes (a level's
// .glb, handed to glTFast): file:// (desktop StreamingAssets, absolute folders), jar:file://
// (Android StreamingAssets) and http(s). Completes on Unity's main thread; a failure faults the
// task with an IOException naming the URL; cancellation completes it with null and aborts the
// request, so a cancelled download stops at once (glTFast's own Load(Uri) keeps downloading).
using System;
using System.IO;
using System.Threading;
using System.Threading.Tasks;
using UnityEngine.Networking;

namespace VWorldLod
{
    public static class WebText
    {
        public static Task<string> GetAsync(string url, CancellationToken cancellation)
        {
            return Get(url, cancellation, handler => handler.text);
        }

        public static Task<byte[]> GetBytesAsync(string url, CancellationToken cancellation)
        {
            return Get(url, cancellation, handler => handler.data);
        }

        static Task<T> Get<T>(string url, CancellationToken cancellation, Func<DownloadHandler, T> content) where T : class
        {
            var done = new TaskCompletionSource<T>();
            UnityWebRequest request = UnityWebRequest.Get(url);
            UnityWebRequestAsyncOperation operation = request.SendWebRequest();
            CancellationTokenRegistration registration = cancellation.Register(() =>
            {
                if (done.TrySetResult(null)) request.Abort();
            });
            operation.completed += _ =>
            {
                registration.Dispose();
                try
                {
                    if (request.result == UnityWebRequest.Result.Success) done.TrySetResult(content(request.downloadHandler));
                    else done.TrySetException(new IOException(url + ": cannot read it (" + request.error + ")"));
                }
                finally
                {
                    request.Dispose();
                }
            };
            return done.Task;
        }
    }
}
