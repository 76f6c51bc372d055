// Sits on a tile root and puts it where its manifest says, relative to the scene's georeference
// (VWorldLodGeoreference; the paper's absolute globe placement without one, or in Globe mode).
// Buildings are children at their relative_placement (tile East/Up/North, metres), so only the
// root needs placing.
//
// The pose is re-applied whenever the root's Transform changed (keepPlaced): when Unity drops a
// prefab into the Scene view it moves the root to the point under the mouse (GameObjectInspector
// .OnSceneDragInternal sets transform.position), and dropping it into the Hierarchy keeps the
// position saved in the prefab, which may come from another origin. Either way the tile goes back
// to its place. The root must sit at the scene root or under unscaled parents (world pose set).
// In the Editor, roots outside the edited scene (Prefab Mode, the Scene view's hidden drag
// preview) are left where they are (AutoPlaces, PlacementScope).
using System;
using System.Collections.Generic;
using UnityEngine;

namespace VWorldLod
{
    [ExecuteAlways]
    [DisallowMultipleComponent]
    public class VWorldLodTilePlacement : MonoBehaviour
    {
        /// <summary>The tile's name ("&lt;level&gt;_&lt;idx&gt;_&lt;idy&gt;").</summary>
        public string tileName = "";
        /// <summary>tile.center: degrees, degrees, metres.</summary>
        public double centerLongitude, centerLatitude, centerElevation;
        /// <summary>globe.earth_radius_m (R, metres) and globe.unity_radius (UR, Unity units).</summary>
        public double earthRadius = 6378137, unityRadius = 6378137;
        /// <summary>Re-apply the manifest's placement when the Transform is moved.</summary>
        public bool keepPlaced = true;

        static readonly List<VWorldLodTilePlacement> active = new List<VWorldLodTilePlacement>();

        /// <summary>
        /// Whether a tile root is placed automatically (when enabled, moved, or the origin moves)
        /// and may get the scene a georeference; null (a player): every root. The Editor
        /// (TilePlacementHook) sets it to PlacementScope.Places fed by Unity.
        /// </summary>
        public static Func<GameObject, bool> AutoPlaces;

        /// <summary>See AutoPlaces.</summary>
        public bool PlacesAutomatically { get { return AutoPlaces == null || AutoPlaces(gameObject); } }

        /// <summary>The active tile roots of all open scenes.</summary>
        public static IList<VWorldLodTilePlacement> All { get { return active.AsReadOnly(); } }

        /// <summary>Copies what the placement needs from a plan.</summary>
        public void Configure(TilePlan plan)
        {
            Configure(plan.TileName, plan.CenterLon, plan.CenterLat, plan.CenterElev, plan.EarthRadius, plan.UnityRadius);
        }

        /// <summary>A frame at lon/lat (degrees), elev (metres) on a globe of R metres and UR Unity units (a tile root or a proxy).</summary>
        public void Configure(string name, double lon, double lat, double elev, double earthRadius, double unityRadius)
        {
            tileName = name;
            centerLongitude = lon;
            centerLatitude = lat;
            centerElevation = elev;
            this.earthRadius = earthRadius;
            this.unityRadius = unityRadius;
        }

        /// <summary>The root's pose (double precision) relative to origin, or on the globe when origin is null.</summary>
        public Placement Pose(GeoOrigin origin)
        {
            if (origin != null) return origin.FramePose(centerLongitude, centerLatitude, centerElevation, earthRadius, unityRadius);
            double[] p = Placement.GlobePosition(centerLongitude, centerLatitude, centerElevation, earthRadius, unityRadius);
            double[] q = Placement.EastUpNorthRotation(centerLongitude, centerLatitude);
            return new Placement(p[0], p[1], p[2], q[0], q[1], q[2], q[3], unityRadius / earthRadius);
        }

        /// <summary>Puts the root at its pose for the scene's georeference.</summary>
        public void Place()
        {
            LodGroupAssembly.ApplyWorldPlacement(transform, Pose(VWorldLodGeoreference.CurrentOrigin));
            transform.hasChanged = false;
        }

        /// <summary>Re-places every active tile root that is placed automatically.</summary>
        public static void PlaceAll()
        {
            foreach (VWorldLodTilePlacement tile in active)
                if (tile.PlacesAutomatically) tile.Place();
        }

        void OnEnable()
        {
            active.Add(this);
            if (PlacesAutomatically) Place();
        }

        void OnDisable()
        {
            active.Remove(this);
        }

        void Update()
        {
            if (keepPlaced && transform.hasChanged && PlacesAutomatically) Place();
        }
    }
}
