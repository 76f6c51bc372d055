// Keeps tile roots where their manifests put them in the Editor, relative to the scene's
// georeference. Unity's Scene-view drop (GameObjectInspector.OnSceneDragInternal) instantiates the
// prefab and then sets transform.position to the point under the mouse; VWorldLodTilePlacement
// re-places on Update when its Transform changed, and this hook does it on every hierarchy change
// too (a drop, a paste, an undo), so it holds even while the Editor does not tick Update. A scene
// that gets a tile but has no georeference gets one at that tile's centre (logged), so the tile
// is placed with small numbers from the start.
using UnityEditor;
using UnityEngine;

namespace VWorldLod.EditorTools
{
    [InitializeOnLoad]
    public static class TilePlacementHook
    {
        static TilePlacementHook()
        {
            EditorApplication.hierarchyChanged += OnHierarchyChanged;
        }

        static void OnHierarchyChanged()
        {
            if (EditorApplication.isPlayingOrWillChangePlaymode) return;
            var tiles = VWorldLodTilePlacement.All;
            if (tiles.Count == 0) return;
            if (VWorldLodGeoreference.Current == null) CreateGeoreference(tiles[0]);
            foreach (VWorldLodTilePlacement tile in tiles)
                if (tile.keepPlaced && tile.transform.hasChanged) tile.Place();
        }

        /// <summary>A georeference at the tile's centre (elevation of the tile centre).</summary>
        public static VWorldLodGeoreference CreateGeoreference(VWorldLodTilePlacement at)
        {
            var go = new GameObject("VWorld LoD Georeference");
            var georeference = go.AddComponent<VWorldLodGeoreference>();
            georeference.SetOrigin(at.centerLongitude, at.centerLatitude, at.centerElevation);
            Undo.RegisterCreatedObjectUndo(go, "Create VWorld LoD Georeference");
            Debug.Log("VWorld LoD: the scene had no georeference: created " + go.name + " at tile " + at.tileName
                      + "'s centre (lon " + at.centerLongitude + ", lat " + at.centerLatitude + "); tiles are placed relative to it");
            return georeference;
        }

        [MenuItem("GameObject/VWorld LoD/Georeference", false, 10)]
        static void CreateFromMenu()
        {
            if (VWorldLodGeoreference.Current != null)
            {
                Debug.LogWarning("VWorld LoD: the scene already has a georeference (" + VWorldLodGeoreference.Current.name + "); one per scene");
                Selection.activeGameObject = VWorldLodGeoreference.Current.gameObject;
                return;
            }
            var tiles = VWorldLodTilePlacement.All;
            if (tiles.Count > 0)
            {
                Selection.activeGameObject = CreateGeoreference(tiles[0]).gameObject;
                return;
            }
            var go = new GameObject("VWorld LoD Georeference");
            go.AddComponent<VWorldLodGeoreference>();
            Undo.RegisterCreatedObjectUndo(go, "Create VWorld LoD Georeference");
            Selection.activeGameObject = go;
        }
    }
}
