// The thin Unity side shared by the Editor importer and the runtime loader: applies a planned
// Placement to a Transform and sets up a building's LODGroup from its LevelPlans.
//
// Frames: Placement values are in the parent's frame (see LodPlan.cs); Unity stores float, so globe
// positions (~6.4e6 units for UR = R) keep ~0.5 unit steps: prefer tile_relative placement.
using UnityEngine;

namespace VWorldLod
{
    public static class LodGroupAssembly
    {
        /// <summary>Sets t's local position, rotation and uniform scale to pose.</summary>
        public static void ApplyPlacement(Transform t, Placement pose)
        {
            t.localPosition = new Vector3((float)pose.px, (float)pose.py, (float)pose.pz);
            t.localRotation = new Quaternion((float)pose.qx, (float)pose.qy, (float)pose.qz, (float)pose.qw);
            float s = (float)pose.scale;
            t.localScale = new Vector3(s, s, s);
        }

        /// <summary>
        /// Adds (or reuses) the LODGroup on root and sets one LOD per level: renderers[k] are the
        /// renderers of level k, heights and fade settings from the plan; bounds recalculated.
        /// </summary>
        public static LODGroup Configure(GameObject root, BuildingPlan building, TilePlan tile, Renderer[][] renderers)
        {
            LODGroup group = root.GetComponent<LODGroup>();
            if (group == null) group = root.AddComponent<LODGroup>();
            var lods = new LOD[building.Levels.Length];
            for (int k = 0; k < lods.Length; k++)
            {
                lods[k] = new LOD((float)building.Levels[k].ScreenRelativeHeight, renderers[k]);
                lods[k].fadeTransitionWidth = (float)building.Levels[k].FadeTransitionWidth;
            }
            group.fadeMode = (LODFadeMode)(int)tile.FadeMode;
            group.animateCrossFading = tile.AnimateCrossFading;
            group.SetLODs(lods);
            group.RecalculateBounds();
            return group;
        }
    }
}
