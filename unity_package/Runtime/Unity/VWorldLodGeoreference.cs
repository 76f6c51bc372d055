// The scene's georeference: one per scene. Its origin (longitude, latitude in degrees, height in
// metres, all double precision) is where the scene's world frame sits: x = East, y = Up,
// z = North there (left-handed, y up, as Unity), in Unity units (UR/R per metre; 1 m for UR = R).
// Every tile root (VWorldLodTilePlacement) is placed relative to it by double-precision math
// (GeoOrigin), so Transforms hold numbers as small as the distance to the origin. Moving the
// origin (SetOrigin, or editing the fields in the Inspector) re-places every tile and tells the
// streamers, e.g. to keep the origin near a camera that travels far.
//
// mode = Globe keeps the paper's absolute placement instead (the Earth's centre at the world
// origin, equations (1)-(2)): float32 steps there are 0.25-0.5 m, so close-ups jitter.
using System;
using System.Collections.Generic;
using UnityEngine;

namespace VWorldLod
{
    [ExecuteAlways]
    [DisallowMultipleComponent]
    public class VWorldLodGeoreference : MonoBehaviour
    {
        public enum Mode { Georeferenced = 0, Globe = 1 }

        /// <summary>Degrees, [-180, 180].</summary>
        public double longitude = 126.978;
        /// <summary>Degrees, [-90, 90].</summary>
        public double latitude = 37.5665;
        /// <summary>Metres (the manifests' vertical datum).</summary>
        public double height;
        public Mode mode = Mode.Georeferenced;

        static readonly List<VWorldLodGeoreference> active = new List<VWorldLodGeoreference>();

        /// <summary>Raised after the origin or the placement mode changed (tiles already re-placed).</summary>
        public static event Action OriginChanged;

        bool dirty;
        string reported;
        GeoOrigin lastGood;

        /// <summary>The scene's georeference (the first active one), or null.</summary>
        public static VWorldLodGeoreference Current
        {
            get { return active.Count > 0 ? active[0] : null; }
        }

        /// <summary>The origin tiles are placed against: null in Globe mode, without a georeference, or when the fields are unusable.</summary>
        public static GeoOrigin CurrentOrigin
        {
            get
            {
                VWorldLodGeoreference g = Current;
                return g == null ? null : g.Origin;
            }
        }

        /// <summary>
        /// This component's origin (see CurrentOrigin). Fields that are not a usable origin (e.g.
        /// while typing in the Inspector) log once why and keep the last usable origin.
        /// </summary>
        public GeoOrigin Origin
        {
            get
            {
                if (mode == Mode.Globe) return null;
                string problem = GeoOrigin.Problem(longitude, latitude, height);
                if (problem != null)
                {
                    if (reported != problem)
                        Debug.LogError("VWorld LoD: " + name + ": " + problem + "; tiles keep "
                                       + (lastGood == null ? "the globe placement" : "the origin " + lastGood) + " until it is fixed");
                    reported = problem;
                    return lastGood;
                }
                reported = null;
                if (lastGood == null || lastGood.Longitude != longitude || lastGood.Latitude != latitude || lastGood.Height != height)
                    lastGood = new GeoOrigin(longitude, latitude, height);
                return lastGood;
            }
        }

        /// <summary>Moves the origin and re-places every tile; false (and an error in the console) when unusable.</summary>
        public bool SetOrigin(double lon, double lat, double heightMetres)
        {
            string problem = GeoOrigin.Problem(lon, lat, heightMetres);
            if (problem != null)
            {
                Debug.LogError("VWorld LoD: " + name + ": " + problem + "; origin left at " + longitude + ", " + latitude);
                return false;
            }
            longitude = lon;
            latitude = lat;
            height = heightMetres;
            PlaceAll();
            return true;
        }

        /// <summary>
        /// Moves the origin to where target is (for a camera that travelled far: float32 precision
        /// is best near the origin) and target to the scene's origin, keeping its geographic place;
        /// tiles are re-placed and streamers told. Radii R and UR as in the manifests (default 1 m
        /// per unit). Other objects of the scene are not moved.
        /// </summary>
        public bool RecenterOn(Transform target, double earthRadius = 6378137, double unityRadius = 6378137)
        {
            GeoOrigin origin = Origin;
            if (origin == null) return false;
            Vector3 p = target.position;
            double[] geo = origin.Geographic(p.x, p.y, p.z, earthRadius, unityRadius);
            if (!SetOrigin(geo[0], geo[1], geo[2])) return false;
            target.position = new Vector3(0, 0, 0);
            return true;
        }

        /// <summary>Re-places every tile root of the scene and notifies listeners.</summary>
        public void PlaceAll()
        {
            dirty = false;
            GeoOrigin origin = Origin;
            if (origin != null && origin.Note() != null) Debug.LogWarning("VWorld LoD: " + name + ": " + origin.Note());
            PlaceTilesAndNotify();
        }

        // Tiles first: listeners (the streamers' cached tile positions) see the new placement.
        static void PlaceTilesAndNotify()
        {
            VWorldLodTilePlacement.PlaceAll();
            Action handler = OriginChanged;
            if (handler != null) handler();
        }

        void OnEnable()
        {
            active.Add(this);
            if (active.Count > 1)
                Debug.LogWarning("VWorld LoD: more than one georeference is active (" + active[0].name + ", " + name + "); tiles use " + active[0].name);
            PlaceAll();
        }

        void OnDisable()
        {
            bool wasCurrent = Current == this;
            active.Remove(this);
            // The next georeference (or the globe placement) takes over: the origin changed.
            if (wasCurrent) PlaceTilesAndNotify();
        }

        // Inspector edits: re-place on the next Update (Transforms are not changed inside OnValidate).
        void OnValidate() { dirty = true; }

        void Update()
        {
            if (dirty) PlaceAll();
        }
    }
}
