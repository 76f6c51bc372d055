// The georeference math (GeoOrigin) against the globe equations, and float32 placement the way
// Unity composes Transforms; plus files from the Python side (exporter.placement as reference).
using System;
using System.Collections.Generic;
using System.IO;

namespace VWorldLod.Tests
{
    public static class GeoreferenceTests
    {
        const double R = 6378137;

        static Placement GlobeFrame(double lon, double lat, double elev, double earthRadius, double unityRadius, double scale)
        {
            double[] p = Placement.GlobePosition(lon, lat, elev, earthRadius, unityRadius);
            double[] q = Placement.EastUpNorthRotation(lon, lat);
            return new Placement(p[0], p[1], p[2], q[0], q[1], q[2], q[3], scale);
        }

        /// <summary>
        /// World position of a child at `local` under a root Transform at `root`, in float32 as a
        /// Unity hierarchy holds and composes it: every stored value and every operation rounded
        /// to float (world = root.position + root.rotation * (root.scale * local.position)).
        /// </summary>
        public static double[] FloatWorld(Placement root, Placement local)
        {
            float rx = (float)root.px, ry = (float)root.py, rz = (float)root.pz, rs = (float)root.scale;
            float qx = (float)root.qx, qy = (float)root.qy, qz = (float)root.qz, qw = (float)root.qw;
            float vx = (float)(rs * (float)local.px), vy = (float)(rs * (float)local.py), vz = (float)(rs * (float)local.pz);
            float tx = (float)(2f * (float)((float)(qy * vz) - (float)(qz * vy)));
            float ty = (float)(2f * (float)((float)(qz * vx) - (float)(qx * vz)));
            float tz = (float)(2f * (float)((float)(qx * vy) - (float)(qy * vx)));
            float wx = (float)(vx + (float)((float)(qw * tx) + (float)((float)(qy * tz) - (float)(qz * ty))));
            float wy = (float)(vy + (float)((float)(qw * ty) + (float)((float)(qz * tx) - (float)(qx * tz))));
            float wz = (float)(vz + (float)((float)(qw * tz) + (float)((float)(qx * ty) - (float)(qy * tx))));
            return new double[] { (float)(rx + wx), (float)(ry + wy), (float)(rz + wz) };
        }

        static double[] Pos(Placement p) { return new[] { p.px, p.py, p.pz }; }

        static double Distance(double[] a, double[] b)
        {
            return Math.Sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) + (a[2] - b[2]) * (a[2] - b[2]));
        }

        public static void Run(TestRunner t)
        {
            t.Check("georef: origin's own frame is the identity, scaled UR/R", () =>
            {
                var o = new GeoOrigin(126.978, 37.5665, 21.5);
                Placement p = o.FramePose(126.978, 37.5665, 21.5, R, 1000);
                Assert.Equal(new Placement(0, 0, 0, 0, 0, 0, 1, 1000 / R).ToString(), p.ToString(), "pose at the origin");
            });
            t.Check("georef: origin's globe frame composed with the scene pose is the globe pose", () =>
            {
                var rng = new Random(17);
                foreach (double ur in new[] { R, 1000.0 })
                    for (int n = 0; n < 200; n++)
                    {
                        double lon0 = rng.NextDouble() * 360 - 180, lat0 = rng.NextDouble() * 180 - 90, h0 = rng.NextDouble() * 100;
                        double lon = lon0 + (rng.NextDouble() - 0.5) * 0.2, lat = Math.Max(-90, Math.Min(90, lat0 + (rng.NextDouble() - 0.5) * 0.2));
                        double elev = rng.NextDouble() * 300 - 50;
                        var o = new GeoOrigin(lon0, lat0, h0);
                        Placement composed = Placement.Compose(GlobeFrame(lon0, lat0, h0, R, ur, 1), o.FramePose(lon, lat, elev, R, ur));
                        ExportedTests.SamePose(GlobeFrame(lon, lat, elev, R, ur, ur / R), composed, "lon " + lon + " lat " + lat, "georef_vs_globe");
                    }
            });
            t.Check("georef: Geographic inverts ScenePosition (moving the origin to the camera)", () =>
            {
                var rng = new Random(29);
                foreach (double ur in new[] { R, 1000.0 })
                    for (int n = 0; n < 100; n++)
                    {
                        var o = new GeoOrigin(rng.NextDouble() * 360 - 180, rng.NextDouble() * 170 - 85, rng.NextDouble() * 50);
                        double lon = o.Longitude + (rng.NextDouble() - 0.5) * 0.1, lat = o.Latitude + (rng.NextDouble() - 0.5) * 0.1, elev = rng.NextDouble() * 500;
                        double[] p = o.ScenePosition(lon, lat, elev, R, ur);
                        double[] back = o.Geographic(p[0], p[1], p[2], R, ur);
                        double lonBack = back[0] - lon > 180 ? back[0] - 360 : back[0] - lon < -180 ? back[0] + 360 : back[0];
                        Assert.Near(lon, lonBack, 1e-9, "lon");
                        Assert.Near(lat, back[1], 1e-9, "lat");
                        Assert.Near(elev, back[2], 1e-6, "elev (m)");
                    }
            });
            t.Check("georef: tiles across the antimeridian are placed continuously", () =>
            {
                var east = new GeoOrigin(180, 10, 0);
                var west = new GeoOrigin(-180, 10, 0);
                double[] a = east.ScenePosition(-179.999, 10.0005, 5, R, R), b = west.ScenePosition(-179.999, 10.0005, 5, R, R);
                double[] c = east.ScenePosition(179.999, 10.0005, 5, R, R);
                Assert.Near(0, Distance(a, b), 1e-6, "origin at +180 or -180");
                Assert.True(a[0] > 100 && a[0] < 120, "-179.999 is ~110 m east of 180: " + a[0]);
                Assert.Near(-a[0], c[0], 1e-6, "+179.999 is as far west");
            });
            t.Check("georef: an origin at a pole gives a valid frame and a note", () =>
            {
                var pole = new GeoOrigin(30, 90, 0);
                Assert.Contains("north pole", pole.Note(), "note");
                double[] p = pole.ScenePosition(30, 89.999, 0, R, R);
                Assert.Near(0, p[0], 1e-6, "along the given meridian: no east offset");
                Assert.True(p[2] < -100 && p[2] > -120, "south of the pole is -North: " + p[2]);
                Assert.True(new GeoOrigin(0, 45, 0).Note() == null, "no note elsewhere");
            });
            foreach (double[] bad in new[] { new[] { 181.0, 0, 0 }, new[] { 0, 90.5, 0 }, new[] { double.NaN, 0, 0 }, new[] { 0, 0, double.PositiveInfinity } })
            {
                double[] b = bad;
                t.Check("georef: refuses lon " + b[0] + " lat " + b[1] + " height " + b[2], () =>
                {
                    string problem = GeoOrigin.Problem(b[0], b[1], b[2]);
                    Assert.True(problem != null && problem.StartsWith("georeference "), "problem: " + problem);
                    Assert.Throws<ArgumentException>(() => new GeoOrigin(b[0], b[1], b[2]), "constructor");
                });
            }
            t.Check("georef: float32 keeps a building 1 km from the origin within 1 mm (globe: not)", () =>
            {
                var o = new GeoOrigin(126.978, 37.5665, 0);
                double lon = 126.978 + 0.0112, lat = 37.5665 + 0.0001; // ~990 m east
                double[] exact = o.ScenePosition(lon, lat, 30, R, R);
                Assert.True(Math.Abs(exact[0]) > 900 && Math.Abs(exact[0]) < 1000, "about 1 km: " + exact[0]);
                var local = new Placement(2.5, 10, -3.25, 0, 0, 0, 1, 1);
                Placement root = o.FramePose(lon, lat, 30, R, R);
                double[] expected = { exact[0], exact[1], exact[2] };
                double[] offset = Placement.Rotate(root.qx, root.qy, root.qz, root.qw, 2.5, 10, -3.25);
                for (int k = 0; k < 3; k++) expected[k] += offset[k];
                double error = Distance(expected, FloatWorld(root, local));
                Assert.True(error < 1e-3, "georeferenced float32 error " + error + " m");
                Placement globeRoot = GlobeFrame(lon, lat, 30, R, R, 1);
                double[] globeExact = Pos(Placement.Compose(globeRoot, local));
                double globeError = Distance(globeExact, FloatWorld(globeRoot, local));
                Assert.True(globeError > 0.01, "globe float32 error " + globeError + " m (jitter of the absolute placement)");
            });
        }

        /// <summary>
        /// Cases from exporter.placement: {"cases": [{"origin": {lon, lat, elev}, "point": {lon, lat, elev},
        /// "earth_radius_m", "unity_radius", "pose": placement dict}]}: GeoOrigin.FramePose must match.
        /// </summary>
        public static void RunCases(TestRunner t, string path)
        {
            var root = (Dictionary<string, object>)PlainJson.Parse(File.ReadAllText(path));
            var cases = (List<object>)root["cases"];
            t.Check("georef cases: " + cases.Count + " from exporter.placement agree to 1e-9", () =>
            {
                Assert.True(cases.Count > 0, "cases");
                foreach (object item in cases)
                {
                    var c = (Dictionary<string, object>)item;
                    var o = (Dictionary<string, object>)c["origin"];
                    var p = (Dictionary<string, object>)c["point"];
                    var origin = new GeoOrigin((double)o["lon"], (double)o["lat"], (double)o["elev"]);
                    Placement pose = origin.FramePose((double)p["lon"], (double)p["lat"], (double)p["elev"], (double)c["earth_radius_m"], (double)c["unity_radius"]);
                    ExportedTests.SamePose(ExportedTests.ToPose(c["pose"]), pose, "origin " + origin + " point " + p["lon"] + ", " + p["lat"], "georef_vs_python");
                }
            });
        }

        /// <summary>
        /// {"origin": {lon, lat, elev}, "manifests": [paths], "expected": [{"tile", "id", "position"}],
        /// "tolerance"}: each building's float32 world position (tile root at RootPose(origin),
        /// building at relative_placement, composed in float) within tolerance (Unity units) of
        /// the expected double-precision position (exporter.placement.enu_offset * UR/R). The
        /// absolute globe placement's float32 error is measured for comparison.
        /// </summary>
        public static void RunFloat32(TestRunner t, string path)
        {
            var root = (Dictionary<string, object>)PlainJson.Parse(File.ReadAllText(path));
            var o = (Dictionary<string, object>)root["origin"];
            var origin = new GeoOrigin((double)o["lon"], (double)o["lat"], (double)o["elev"]);
            double tolerance = (double)root["tolerance"];
            var expected = new Dictionary<string, double[]>();
            foreach (object item in (List<object>)root["expected"])
            {
                var e = (Dictionary<string, object>)item;
                var p = (List<object>)e["position"];
                expected[(string)e["tile"] + "/" + (string)e["id"]] = new[] { (double)p[0], (double)p[1], (double)p[2] };
            }
            t.Check("float32: " + expected.Count + " buildings under a georeference within " + tolerance + " of exact", () =>
            {
                int checkedCount = 0;
                double worst = 0, worstGlobe = 0;
                foreach (object manifest in (List<object>)root["manifests"])
                {
                    TilePlan plan = LodPlanner.Load((string)manifest, new PlainJsonManifestParser(), p => true);
                    foreach (BuildingPlan b in plan.Buildings)
                    {
                        double[] exact;
                        if (!expected.TryGetValue(plan.TileName + "/" + b.Id, out exact)) continue;
                        double error = Distance(exact, FloatWorld(plan.RootPose(origin), b.Relative));
                        worst = Math.Max(worst, error);
                        Assert.True(error <= tolerance, plan.TileName + "/" + b.Id + ": float32 error " + error);
                        double[] globeExact = Pos(Placement.Compose(plan.RootPose(null), b.Relative));
                        worstGlobe = Math.Max(worstGlobe, Distance(globeExact, FloatWorld(plan.RootPose(null), b.Relative)));
                        checkedCount++;
                    }
                }
                Assert.Equal(expected.Count, checkedCount, "buildings checked");
                Console.WriteLine("MEASURE float32_georeferenced_max_error " + worst.ToString("R"));
                Console.WriteLine("MEASURE float32_globe_max_error " + worstGlobe.ToString("R"));
            });
        }
    }
}
