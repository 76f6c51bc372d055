// Placement arithmetic checked against Unity's conventions and the paper's equations (1)-(2).
using System;

namespace VWorldLod.Tests
{
    public static class PoseTests
    {
        const double Eps = 1e-12;

        static void Vec(double x, double y, double z, double[] v, double tolerance, string what)
        {
            Assert.Near(x, v[0], tolerance, what + ".x");
            Assert.Near(y, v[1], tolerance, what + ".y");
            Assert.Near(z, v[2], tolerance, what + ".z");
        }

        static double[] Apply(double[] q, double x, double y, double z)
        {
            return Placement.Rotate(q[0], q[1], q[2], q[3], x, y, z);
        }

        public static void Run(TestRunner t)
        {
            t.Check("pose: AngleAxis(90, up) * forward == right (Unity)", () =>
            {
                double[] q = Placement.AngleAxis(90, 0, 1, 0);
                Vec(1, 0, 0, Apply(q, 0, 0, 1), Eps, "forward turned");
            });
            t.Check("pose: product applies the right factor first (Unity's a * b)", () =>
            {
                double[] a = Placement.AngleAxis(90, 0, 1, 0), b = Placement.AngleAxis(90, 1, 0, 0);
                double[] ab = Placement.Multiply(a[0], a[1], a[2], a[3], b[0], b[1], b[2], b[3]);
                double[] step = Apply(b, 0, 0, 1);
                double[] expected = Apply(a, step[0], step[1], step[2]);
                Vec(expected[0], expected[1], expected[2], Apply(ab, 0, 0, 1), Eps, "(a*b)*v == a*(b*v)");
            });
            t.Check("pose: compose with identity changes nothing", () =>
            {
                var p = new Placement(1, 2, 3, 0, 0.6, 0, 0.8, 2);
                Placement c = Placement.Compose(Placement.Identity, p);
                Assert.Equal(p.ToString(), c.ToString(), "identity parent");
                c = Placement.Compose(p, Placement.Identity);
                Assert.Equal(p.ToString(), c.ToString(), "identity child");
            });
            t.Check("pose: compose = parent.position + parent.rotation * (parent.scale * child.position)", () =>
            {
                var parent = new Placement(10, 20, 30, 0, Math.Sqrt(0.5), 0, Math.Sqrt(0.5), 3); // 90 deg about y
                var child = new Placement(1, 0, 0, 0, 0, 0, 1, 0.5);
                Placement c = Placement.Compose(parent, child);
                Vec(10, 20, 27, new[] { c.px, c.py, c.pz }, 1e-12, "position"); // +x turns to -z
                Assert.Near(1.5, c.scale, Eps, "scale");
            });
            t.Check("pose: compose is associative", () =>
            {
                var rng = new Random(3);
                for (int n = 0; n < 50; n++)
                {
                    Placement a = RandomPose(rng), b = RandomPose(rng), c = RandomPose(rng);
                    Placement left = Placement.Compose(Placement.Compose(a, b), c), right = Placement.Compose(a, Placement.Compose(b, c));
                    Vec(left.px, left.py, left.pz, new[] { right.px, right.py, right.pz }, 1e-9, "position");
                    Vec(left.qx, left.qy, left.qz, new[] { right.qx, right.qy, right.qz }, 1e-12, "rotation");
                }
            });
            t.Check("globe: equations (1)-(2) at reference points", () =>
            {
                const double R = 6378137, UR = 1000;
                Vec(0, 0, -UR, Placement.GlobePosition(0, 0, 0, R, UR), 1e-9, "lat 0 lon 0 on -z");
                Vec(UR, 0, 0, Placement.GlobePosition(90, 0, 0, R, UR), 1e-9, "lon 90 E on +x");
                Vec(0, UR, 0, Placement.GlobePosition(17, 90, 0, R, UR), 1e-9, "north pole on +y");
                Vec(0, 0, -2 * UR, Placement.GlobePosition(0, 0, R, R, UR), 1e-9, "elev R doubles h");
            });
            t.Check("globe: East/Up/North rotation maps local axes to the globe's", () =>
            {
                var rng = new Random(5);
                for (int n = 0; n < 50; n++)
                {
                    double lon = rng.NextDouble() * 360 - 180, lat = rng.NextDouble() * 178 - 89;
                    double[] q = Placement.EastUpNorthRotation(lon, lat);
                    double l = lon * Math.PI / 180;
                    double[] up = Placement.GlobePosition(lon, lat, 0, 1, 1);
                    Vec(up[0], up[1], up[2], Apply(q, 0, 1, 0), 1e-12, "up is the radial direction");
                    Vec(Math.Cos(l), 0, Math.Sin(l), Apply(q, 1, 0, 0), 1e-12, "east");
                    // North points towards increasing latitude.
                    double[] north = Apply(q, 0, 0, 1);
                    double[] further = Placement.GlobePosition(lon, lat + 1e-6, 0, 1, 1);
                    double dot = north[0] * (further[0] - up[0]) + north[1] * (further[1] - up[1]) + north[2] * (further[2] - up[2]);
                    Assert.True(dot > 0, "north towards the pole at lat " + lat);
                }
            });
            t.Check("globe: quaternion from matrix round-trips", () =>
            {
                var rng = new Random(7);
                for (int n = 0; n < 100; n++)
                {
                    double[] axis = Normalize(rng.NextDouble() - 0.5, rng.NextDouble() - 0.5, rng.NextDouble() - 0.5);
                    double[] q = Placement.AngleAxis(rng.NextDouble() * 360 - 180, axis[0], axis[1], axis[2]);
                    double[] c0 = Apply(q, 1, 0, 0), c1 = Apply(q, 0, 1, 0), c2 = Apply(q, 0, 0, 1);
                    double[] back = Placement.QuaternionFromMatrix(c0[0], c1[0], c2[0], c0[1], c1[1], c2[1], c0[2], c1[2], c2[2]);
                    double sign = q[3] < 0 ? -1 : 1;
                    for (int k = 0; k < 4; k++) Assert.Near(sign * q[k], back[k], 1e-12, "component " + k);
                }
            });
        }

        static double[] Normalize(double x, double y, double z)
        {
            double n = Math.Sqrt(x * x + y * y + z * z);
            return new[] { x / n, y / n, z / n };
        }

        static Placement RandomPose(Random rng)
        {
            double[] axis = Normalize(rng.NextDouble() - 0.5, rng.NextDouble() - 0.5, rng.NextDouble() - 0.5);
            double[] q = Placement.AngleAxis(rng.NextDouble() * 360, axis[0], axis[1], axis[2]);
            return new Placement(rng.NextDouble() * 100, rng.NextDouble() * 100, rng.NextDouble() * 100, q[0], q[1], q[2], q[3], 0.5 + rng.NextDouble());
        }
    }
}
