// Which level of a building the view needs, the way Unity's LODGroup picks one, plus the
// texture-aware error of each level (the manifest's per-level error_m). Pure functions, no state.
//
// Screen-relative height (UnityCsReference, Editor/Mono/Inspector/LODGroupEditor and LODUtility):
// h = LODGroup.size * QualitySettings.lodBias / (2 d tan(fov / 2)), d from the camera to the
// group's bounds centre; level k shows while h >= its transition height and h < the one above;
// below the last height the building is culled. Screen-space error in pixels (3D Tiles'):
// error * screenHeight / (2 d tan(fov / 2)).
using System;

namespace VWorldLod
{
    public static class LevelChoice
    {
        /// <summary>The size (metres) of a building whose manifest has no bounds (before 0.4.2).</summary>
        public const double DefaultSizeM = 30;

        /// <summary>LODGroup's screen-relative height of a group sizeM across at distanceM (both metres).</summary>
        public static double RelativeHeight(double sizeM, double distanceM, double fovDegrees, double lodBias)
        {
            double d = Math.Max(distanceM, 1e-6);
            return sizeM * lodBias / (2 * d * Math.Tan(fovDegrees * Math.PI / 360.0));
        }

        /// <summary>The level the LODGroup shows at relative height h: the first whose transition h reaches; -1 below the last (culled).</summary>
        public static int TransitionLevel(BuildingPlan building, double h)
        {
            for (int k = 0; k < building.Levels.Length; k++)
                if (h >= building.Levels[k].ScreenRelativeHeight) return k;
            return -1;
        }

        /// <summary>
        /// The coarsest level whose error (LevelPlan.ErrorM, metres; NaN = unknown, not limiting)
        /// looks at most maxPixels large at distanceM on a screen screenHeight pixels tall.
        /// </summary>
        public static int ErrorLevel(BuildingPlan building, double distanceM, double screenHeight, double fovDegrees, double maxPixels)
        {
            for (int k = building.Levels.Length - 1; k > 0; k--)
            {
                double e = building.Levels[k].ErrorM;
                if (double.IsNaN(e) || ProxyStreamer.ScreenSpaceError(e, distanceM, screenHeight, fovDegrees) <= maxPixels) return k;
            }
            return 0;
        }

        /// <summary>
        /// The level the building needs at distanceM: what its LODGroup shows there, or a finer
        /// one where that level's error would look larger than maxPixels; -1 when it is culled.
        /// </summary>
        public static int Needed(BuildingPlan building, double distanceM, double screenHeight, double fovDegrees, double lodBias, double maxPixels)
        {
            double size = double.IsNaN(building.Size) ? DefaultSizeM : building.Size;
            int shown = TransitionLevel(building, RelativeHeight(size, distanceM, fovDegrees, lodBias));
            if (shown < 0) return -1;
            return Math.Min(shown, ErrorLevel(building, distanceM, screenHeight, fovDegrees, maxPixels));
        }
    }
}
