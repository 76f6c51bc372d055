// The thin Unity side shared by the Editor importer and the runtime loader: applies a planned
// Placement to a Transform and sets up a building's LODGroup from its LevelPlans.
//
// Frames: Placement values are in the parent's frame (see LodPlan.cs); Unity stores float, so
// globe positions (~6.4e6 units for UR = R) keep 0.25-0.5 unit steps: place tile roots relative
// to a georeference (VWorldLodGeoreference) to keep them small.
using System.Collections.Generic;
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

        /// <summary>Sets t's world position and rotation and its local uniform scale (parents unscaled) to pose.</summary>
        public static void ApplyWorldPlacement(Transform t, Placement pose)
        {
            t.SetPositionAndRotation(new Vector3((float)pose.px, (float)pose.py, (float)pose.pz),
                                     new Quaternion((float)pose.qx, (float)pose.qy, (float)pose.qz, (float)pose.qw));
            float s = (float)pose.scale;
            t.localScale = new Vector3(s, s, s);
        }

        /// <summary>
        /// The LODGroup of a building of which only `levels` (ascending) are loaded so far:
        /// levelObjects[i] holds renderers[i], those of levels[i]; heights from
        /// LodPlanner.LoadedHeights. The level objects are activated first, so that the LODs and
        /// the bounds are set from active renderers.
        /// </summary>
        public static LODGroup ConfigureLoaded(GameObject root, BuildingPlan building, TilePlan tile, int[] levels, GameObject[] levelObjects, Renderer[][] renderers)
        {
            foreach (GameObject level in levelObjects) level.SetActive(true);
            BuildingAttributes.Attach(root, building); // id and attributes: prefab and streamed building
            double[] heights = LodPlanner.LoadedHeights(building, levels);
            LODGroup group = root.GetComponent<LODGroup>();
            if (group == null) group = root.AddComponent<LODGroup>();
            var lods = new LOD[levels.Length];
            for (int i = 0; i < lods.Length; i++)
            {
                lods[i] = new LOD((float)heights[i], renderers[i]);
                lods[i].fadeTransitionWidth = (float)building.Levels[levels[i]].FadeTransitionWidth;
            }
            group.fadeMode = (LODFadeMode)(int)tile.FadeMode;
            group.animateCrossFading = tile.AnimateCrossFading;
            group.SetLODs(lods);
            group.RecalculateBounds();
            return group;
        }

        /// <summary>
        /// Adds (or reuses) the LODGroup on root and sets one LOD per level: levelObjects[k] (made
        /// active) holds renderers[k], the renderers of level k; heights and fade settings from
        /// the plan; bounds recalculated.
        /// </summary>
        public static LODGroup Configure(GameObject root, BuildingPlan building, TilePlan tile, GameObject[] levelObjects, Renderer[][] renderers)
        {
            return ConfigureLoaded(root, building, tile, AllLevels(building), levelObjects, renderers);
        }

        /// <summary>ConfigureLoaded over levels loaded at run time: loaded[i] is level levels[i].</summary>
        public static LODGroup ConfigureLoaded(GameObject root, BuildingPlan building, TilePlan tile, int[] levels, IList<LoadedLevel> loaded)
        {
            var objects = new GameObject[loaded.Count];
            var renderers = new Renderer[loaded.Count][];
            for (int i = 0; i < objects.Length; i++)
            {
                objects[i] = loaded[i].Root;
                renderers[i] = loaded[i].Renderers;
            }
            return ConfigureLoaded(root, building, tile, levels, objects, renderers);
        }

        /// <summary>0, 1, ..., the building's last level.</summary>
        public static int[] AllLevels(BuildingPlan building)
        {
            var all = new int[building.Levels.Length];
            for (int k = 0; k < all.Length; k++) all[k] = k;
            return all;
        }

        /// <summary>Logs why the tile's fade settings will not show as asked (LodPlanner.FadeWarning); true when it did.</summary>
        public static bool WarnAboutFade(TilePlan tile)
        {
            string warning = LodPlanner.FadeWarning(tile);
            if (warning != null) Debug.LogWarning("VWorld LoD: " + warning);
            return warning != null;
        }
    }
}
