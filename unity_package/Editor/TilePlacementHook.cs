// Keeps tile roots where their manifests put them in the Editor, relative to the scene's
// georeference. Unity's Scene-view drop (GameObjectInspector.OnSceneDragInternal) instantiates the
// prefab and then sets transform.position to the point under the mouse; VWorldLodTilePlacement
// re-places on Update when its Transform changed, and this hook does it on every hierarchy change
// too (a drop, a paste, an undo), so it holds even while the Editor does not tick Update. A scene
// that gets a tile but has no georeference gets one at that tile's centre (logged), so the tile
// is placed with small numbers from the start. Tile roots outside the edited scene (Prefab Mode,
// the hidden drag preview before a drop, preview scenes) are neither placed nor given a
// georeference (PlacementScope): a cancelled drag leaves nothing behind.
using System.Collections.Generic;
using UnityEditor;
using UnityEditor.SceneManagement;
using UnityEngine;

namespace VWorldLod.EditorTools
{
    [InitializeOnLoad]
    public static class TilePlacementHook
    {
        static TilePlacementHook()
        {
            VWorldLodTilePlacement.AutoPlaces = InEditedScene;
            EditorApplication.hierarchyChanged += OnHierarchyChanged;
        }

        /// <summary>PlacementScope.Places for go, from what the Editor says about it.</summary>
        public static bool InEditedScene(GameObject go)
        {
            PrefabStage stage = PrefabStageUtility.GetPrefabStage(go);
            return PlacementScope.Places(stage != null, EditorSceneManager.IsPreviewSceneObject(go),
                                         (go.hideFlags & HideFlags.HideInHierarchy) != 0);
        }

        static void OnHierarchyChanged()
        {
            if (EditorApplication.isPlayingOrWillChangePlaymode) return;
            var tiles = VWorldLodTilePlacement.All;
            VWorldLodTilePlacement site = GeoreferenceSite(tiles);
            if (site != null && VWorldLodGeoreference.Current == null) CreateGeoreference(site);
            foreach (VWorldLodTilePlacement tile in tiles)
                if (tile.keepPlaced && tile.transform.hasChanged && tile.PlacesAutomatically) tile.Place();
        }

        /// <summary>The tile a missing georeference is created at: the first one placed automatically, or null.</summary>
        public static VWorldLodTilePlacement GeoreferenceSite(IList<VWorldLodTilePlacement> tiles)
        {
            foreach (VWorldLodTilePlacement tile in tiles)
                if (tile.PlacesAutomatically) return tile;
            return null;
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
            VWorldLodTilePlacement site = GeoreferenceSite(VWorldLodTilePlacement.All);
            if (site != null)
            {
                Selection.activeGameObject = CreateGeoreference(site).gameObject;
                return;
            }
            var go = new GameObject("VWorld LoD Georeference");
            go.AddComponent<VWorldLodGeoreference>();
            Undo.RegisterCreatedObjectUndo(go, "Create VWorld LoD Georeference");
            Selection.activeGameObject = go;
        }
    }
}
