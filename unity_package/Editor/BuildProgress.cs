// How a build shows its progress. A build asked for from the menu shows Unity's modal, cancellable
// progress bar; an automatic build (a manifest imported: copying a tile in, a Library rebuild, a
// fresh clone) reports to Unity's non-modal background tasks (Progress API, the bar at the bottom
// right of the Editor) and never blocks the Editor with a dialog.
using UnityEditor;

namespace VWorldLod.EditorTools
{
    /// <summary>Who asked for a build.</summary>
    public enum BuildTrigger
    {
        /// <summary>Tools → VWorld LoD → Build LOD Groups from Manifest…: always rebuilds, modal cancellable bar.</summary>
        Menu,
        /// <summary>A lod_manifest.json was imported: skipped when up to date (BuildStamp), background progress.</summary>
        Automatic,
    }

    /// <summary>Progress of one build: Step per building (true: the user cancelled), Done at the end.</summary>
    public interface IBuildProgress
    {
        bool Step(string info, float fraction);
        void Done(bool succeeded);
    }

    public static class BuildProgress
    {
        const string Title = "VWorld LoD";

        /// <summary>The progress display for a build asked for by trigger.</summary>
        public static IBuildProgress For(BuildTrigger trigger, string manifestPath)
        {
            if (trigger == BuildTrigger.Menu) return new ModalProgress();
            return new BackgroundProgress(manifestPath);
        }

        /// <summary>Whether a build asked for by trigger is skipped when BuildStamp says the prefabs are up to date.</summary>
        public static bool SkipsWhenUpToDate(BuildTrigger trigger)
        {
            return trigger == BuildTrigger.Automatic;
        }

        /// <summary>EditorUtility's modal, cancellable progress bar.</summary>
        public class ModalProgress : IBuildProgress
        {
            public bool Step(string info, float fraction)
            {
                return EditorUtility.DisplayCancelableProgressBar(Title, info, fraction);
            }

            public void Done(bool succeeded)
            {
                EditorUtility.ClearProgressBar();
            }
        }

        /// <summary>A background task in Unity's Progress window (no dialog; not cancellable).</summary>
        public class BackgroundProgress : IBuildProgress
        {
            readonly string manifestPath;
            int id = -1;

            public BackgroundProgress(string manifestPath)
            {
                this.manifestPath = manifestPath;
            }

            public bool Step(string info, float fraction)
            {
                if (id < 0) id = Progress.Start(Title, "building prefabs of " + manifestPath);
                Progress.Report(id, fraction, info);
                return false;
            }

            public void Done(bool succeeded)
            {
                if (id >= 0) Progress.Finish(id, succeeded ? Progress.Status.Succeeded : Progress.Status.Failed);
                id = -1;
            }
        }
    }
}
