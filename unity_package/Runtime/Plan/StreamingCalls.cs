// What TileStreamer and ProxyStreamer share about calling their backends: a backend call that
// throws becomes a faulted task, a callback that throws is reported (never stops streaming), and
// the innermost exception's message is the one worth reporting.
using System;
using System.Threading.Tasks;

namespace VWorldLod
{
    public static class StreamingCalls
    {
        /// <summary>The task start() returns; a completed null one for null, a faulted one when start() throws.</summary>
        public static Task<T> Call<T>(Func<Task<T>> start)
        {
            try
            {
                Task<T> task = start();
                if (task != null) return task;
                var none = new TaskCompletionSource<T>();
                none.SetResult(default(T));
                return none.Task;
            }
            catch (Exception e)
            {
                var failed = new TaskCompletionSource<T>();
                failed.SetException(e);
                return failed.Task;
            }
        }

        /// <summary>Runs action; an exception goes to report (prefixed), and one from report itself is dropped.</summary>
        public static void Safe(Action action, Action<string> report, string prefix)
        {
            try
            {
                action();
            }
            catch (Exception e)
            {
                try
                {
                    report(prefix + Innermost(e).Message);
                }
                catch (Exception)
                {
                    // Reporting itself failed: nothing left to tell; streaming goes on.
                }
            }
        }

        /// <summary>e without its AggregateException wrappers.</summary>
        public static Exception Innermost(Exception e)
        {
            while (e is AggregateException && e.InnerException != null) e = e.InnerException;
            return e;
        }
    }
}
