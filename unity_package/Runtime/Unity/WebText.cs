// Reads a text file (tile index, manifest) from a URL with UnityWebRequest: file:// (desktop
// StreamingAssets, absolute folders), jar:file:// (Android StreamingAssets) and http(s).
// Completes on Unity's main thread; a failure faults the task with an IOException naming the URL;
// cancellation completes it with null and aborts the request.
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
            var done = new TaskCompletionSource<string>();
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
                    if (request.result == UnityWebRequest.Result.Success) done.TrySetResult(request.downloadHandler.text);
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
