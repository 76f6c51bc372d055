// The scene's georeference origin and the double-precision placement of tiles relative to it.
//
// Frames:
//   scene frame (georeferenced): East/Up/North at the origin (x = East, y = Up, z = North; left-
//     handed, y up, as Unity), in Unity units: UR/R units per metre (1 unit = 1 m for UR = R);
//   Unity globe frame: the paper's equations (1)-(2) (see Placement.cs), Unity units.
// A tile root placed here is the tile's globe placement seen from the origin's East/Up/North
// frame: position = the tile centre's East/Up/North offset from the origin times UR/R, rotation =
// East/Up/North at the origin inverted, times East/Up/North at the tile centre, scale UR/R. So
// numbers in Transforms stay as small as the distance to the origin (float32 keeps ~0.1 mm at
// 1 km), whereas the globe placement puts ~6.4e6 into them (float32 steps of 0.5 m).
//
// The offset is computed as exporter/placement.py's enu_offset does (the reference it is tested
// against): from differences of angles with the haversine identity 1 - cos c = 2 hav(c), never by
// subtracting two Earth-sized vectors, so nearby points lose no digits. Longitudes are only used
// through sin/cos of differences, so tiles across the antimeridian from the origin are placed
// continuously; at a pole East/North follow the origin's longitude (any longitude is a valid frame).
using System;
using System.Globalization;

namespace VWorldLod
{
    public sealed class GeoOrigin
    {
        /// <summary>Degrees, in [-180, 180].</summary>
        public readonly double Longitude;
        /// <summary>Degrees, in [-90, 90].</summary>
        public readonly double Latitude;
        /// <summary>Metres above the sphere (same vertical datum as the manifests' elev).</summary>
        public readonly double Height;

        /// <summary>Throws ArgumentException (see Problem) for an unusable origin.</summary>
        public GeoOrigin(double longitude, double latitude, double height)
        {
            string problem = Problem(longitude, latitude, height);
            if (problem != null) throw new ArgumentException(problem);
            Longitude = longitude;
            Latitude = latitude;
            Height = height;
        }

        /// <summary>Why lon/lat/height cannot be an origin, or null when they can.</summary>
        public static string Problem(double longitude, double latitude, double height)
        {
            if (double.IsNaN(longitude) || double.IsInfinity(longitude) || longitude < -180 || longitude > 180)
                return "georeference longitude " + Text(longitude) + " is not in [-180, 180] degrees";
            if (double.IsNaN(latitude) || double.IsInfinity(latitude) || latitude < -90 || latitude > 90)
                return "georeference latitude " + Text(latitude) + " is not in [-90, 90] degrees";
            if (double.IsNaN(height) || double.IsInfinity(height) || Math.Abs(height) > 1e7)
                return "georeference height " + Text(height) + " m is not a finite height within 10,000 km of the sphere";
            return null;
        }

        /// <summary>A note worth a console line (origin at a pole), or null.</summary>
        public string Note()
        {
            if (Math.Abs(Latitude) > 90 - 1e-6)
                return "georeference origin at the " + (Latitude > 0 ? "north" : "south") + " pole: East and North there follow the longitude given (" + Text(Longitude) + ")";
            return null;
        }

        /// <summary>
        /// (3,) East/Up/North metres of (lon, lat, elev) in the frame at (lon0, lat0, elev0), on a
        /// sphere of earthRadius metres (exporter.placement.enu_offset).
        /// </summary>
        public static double[] EnuOffset(double lon, double lat, double elev, double lon0, double lat0, double elev0, double earthRadius)
        {
            const double rad = Math.PI / 180.0;
            double phi = lat * rad, phi0 = lat0 * rad;
            double dLam = (lon - lon0) * rad, dPhi = (lat - lat0) * rad;
            double havLam = Sq(Math.Sin(0.5 * dLam)), havPhi = Sq(Math.Sin(0.5 * dPhi));
            double east = Math.Cos(phi) * Math.Sin(dLam);
            double north = Math.Sin(dPhi) + 2.0 * Math.Cos(phi) * Math.Sin(phi0) * havLam;
            double upMinusOne = -2.0 * (havPhi + Math.Cos(phi) * Math.Cos(phi0) * havLam);
            double radius = earthRadius + elev;
            double up = (elev - elev0) + radius * upMinusOne;
            return new[] { radius * east, up, radius * north };
        }

        /// <summary>(3,) scene position (Unity units) of lon/lat (degrees) and elev (metres).</summary>
        public double[] ScenePosition(double lon, double lat, double elev, double earthRadius, double unityRadius)
        {
            double[] enu = EnuOffset(lon, lat, elev, Longitude, Latitude, Height, earthRadius);
            double s = unityRadius / earthRadius;
            return new[] { enu[0] * s, enu[1] * s, enu[2] * s };
        }

        /// <summary>
        /// The scene pose of the East/Up/North frame at lon/lat/elev, in Unity units per metre
        /// UR/R: where a tile root (or a building) with that reference point goes.
        /// </summary>
        public Placement FramePose(double lon, double lat, double elev, double earthRadius, double unityRadius)
        {
            double[] p = ScenePosition(lon, lat, elev, earthRadius, unityRadius);
            double[] q0 = Placement.EastUpNorthRotation(Longitude, Latitude);
            double[] q = Placement.EastUpNorthRotation(lon, lat);
            double[] r = Placement.Multiply(-q0[0], -q0[1], -q0[2], q0[3], q[0], q[1], q[2], q[3]);
            if (r[3] < 0) { r[0] = -r[0]; r[1] = -r[1]; r[2] = -r[2]; r[3] = -r[3]; }
            return new Placement(p[0], p[1], p[2], r[0], r[1], r[2], r[3], unityRadius / earthRadius);
        }

        /// <summary>
        /// (3,) lon, lat (degrees) and elev (metres) of the scene point (x, y, z) (Unity units):
        /// the inverse of ScenePosition, through the globe frame (exact to ~1e-9 m per metre of
        /// distance from the origin; meant for moving the origin, e.g. to where the camera is).
        /// </summary>
        public double[] Geographic(double x, double y, double z, double earthRadius, double unityRadius)
        {
            double toMetres = earthRadius / unityRadius;
            double[] q = Placement.EastUpNorthRotation(Longitude, Latitude);
            double[] d = Placement.Rotate(q[0], q[1], q[2], q[3], x * toMetres, y * toMetres, z * toMetres);
            double[] o = Placement.GlobePosition(Longitude, Latitude, Height, earthRadius, earthRadius);
            double gx = o[0] + d[0], gy = o[1] + d[1], gz = o[2] + d[2];
            double horizontal = Math.Sqrt(gx * gx + gz * gz);
            // Unity globe frame: x = h cos(lat) sin(lon), y = h sin(lat), z = -h cos(lat) cos(lon).
            double lon = Math.Atan2(gx, -gz) * 180.0 / Math.PI;
            double lat = Math.Atan2(gy, horizontal) * 180.0 / Math.PI;
            double elev = Math.Sqrt(gx * gx + gy * gy + gz * gz) - earthRadius;
            return new[] { lon, lat, elev };
        }

        /// <summary>The scene pose of a tile's root: its manifest's tile centre, elev, globe radii.</summary>
        public Placement TileRoot(TileManifest m)
        {
            return FramePose(m.tile.center.lon, m.tile.center.lat, m.tile.center.elev, m.globe.earth_radius_m, m.globe.unity_radius);
        }

        public override string ToString()
        {
            return "lon " + Text(Longitude) + ", lat " + Text(Latitude) + ", height " + Text(Height) + " m";
        }

        static double Sq(double x) { return x * x; }

        static string Text(double x) { return x.ToString("R", CultureInfo.InvariantCulture); }
    }
}
