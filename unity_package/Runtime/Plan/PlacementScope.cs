// Which tile roots the Editor places by itself. VWorldLodTilePlacement and TilePlacementHook run in
// the Editor ([ExecuteAlways], hierarchy changes), where a tile root also shows up outside the
// scene being edited: in Prefab Mode, where placing would re-pose the prefab asset's root (and
// Prefab Mode saves it), and as the Scene view's drag preview, which Unity instantiates hidden
// (HideFlags.HideInHierarchy, GameObjectInspector.OnSceneDragInternal) and unhides on drop or
// destroys when the drag is cancelled: a georeference created for it would be left behind. The
// Editor feeds the facts (PrefabStageUtility, EditorSceneManager, hideFlags) to this rule.
namespace VWorldLod
{
    public static class PlacementScope
    {
        /// <summary>
        /// True when a tile root belongs to an edited scene: it is placed automatically and may
        /// get the scene a georeference. False when it is in a Prefab Mode stage, in another
        /// preview scene (Inspector previews), or hidden in the hierarchy (a drag preview until
        /// the drop).
        /// </summary>
        public static bool Places(bool inPrefabStage, bool inPreviewScene, bool hiddenInHierarchy)
        {
            return !inPrefabStage && !inPreviewScene && !hiddenInHierarchy;
        }
    }
}
