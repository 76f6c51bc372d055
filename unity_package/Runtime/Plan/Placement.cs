// Placement arithmetic in double precision, Unity's conventions, no Unity types.
//
// Sources: the paper's equations (1)-(2) and Fig. 5 (globe placement), worked out in
// docs/reference/frames-and-placement.md; Unity's Transform composition
//   world.position = parent.position + parent.rotation * (parent.scale * child.position)
//   world.rotation = parent.rotation * child.rotation,  world.scale = parent.scale * child.scale
// and Unity's (ordinary, Hamilton) quaternion product, components x, y, z, w.
//
// Frames: a Placement places a child frame in its parent's frame; which frames depends on use
// (tile root: Unity globe frame, Unity units; building relative: tile East/Up/North, metres).
using System;

namespace VWorldLod
{
    /// <summary>Position (x, y, z), rotation quaternion (x, y, z, w), uniform scale.</summary>
    [Serializable]
    public struct Placement
    {
        public double px, py, pz;
        public double qx, qy, qz, qw;
        public double scale;

        public Placement(double px, double py, double pz, double qx, double qy, double qz, double qw, double scale)
        {
            this.px = px; this.py = py; this.pz = pz;
            this.qx = qx; this.qy = qy; this.qz = qz; this.qw = qw;
            this.scale = scale;
        }

        public static Placement Identity { get { return new Placement(0, 0, 0, 0, 0, 0, 1, 1); } }

        /// <summary>The pose of a placement dict ({"position", "rotation", "scale"}).</summary>
        public static Placement FromData(PlacementData p)
        {
            return new Placement(p.position[0], p.position[1], p.position[2],
                            p.rotation[0], p.rotation[1], p.rotation[2], p.rotation[3], p.scale);
        }

        /// <summary>Unity's hierarchy: the child's pose seen from the parent's parent.</summary>
        public static Placement Compose(Placement parent, Placement child)
        {
            double[] offset = Rotate(parent.qx, parent.qy, parent.qz, parent.qw,
                                     parent.scale * child.px, parent.scale * child.py, parent.scale * child.pz);
            double[] q = Multiply(parent.qx, parent.qy, parent.qz, parent.qw, child.qx, child.qy, child.qz, child.qw);
            return new Placement(parent.px + offset[0], parent.py + offset[1], parent.pz + offset[2],
                            q[0], q[1], q[2], q[3], parent.scale * child.scale);
        }

        /// <summary>Hamilton product a * b (apply b, then a), as Unity's Quaternion operator *.</summary>
        public static double[] Multiply(double ax, double ay, double az, double aw,
                                        double bx, double by, double bz, double bw)
        {
            return new[]
            {
                aw * bx + ax * bw + ay * bz - az * by,
                aw * by + ay * bw + az * bx - ax * bz,
                aw * bz + az * bw + ax * by - ay * bx,
                aw * bw - ax * bx - ay * by - az * bz,
            };
        }

        /// <summary>The unit quaternion (x, y, z, w) applied to vector v, as Unity's Quaternion * Vector3.</summary>
        public static double[] Rotate(double qx, double qy, double qz, double qw, double vx, double vy, double vz)
        {
            // v' = v + 2w (u x v) + 2 u x (u x v), u = (qx, qy, qz)
            double tx = 2 * (qy * vz - qz * vy);
            double ty = 2 * (qz * vx - qx * vz);
            double tz = 2 * (qx * vy - qy * vx);
            return new[]
            {
                vx + qw * tx + (qy * tz - qz * ty),
                vy + qw * ty + (qz * tx - qx * tz),
                vz + qw * tz + (qx * ty - qy * tx),
            };
        }

        /// <summary>Rotation by angleDegrees about a unit axis, as Unity's Quaternion.AngleAxis.</summary>
        public static double[] AngleAxis(double angleDegrees, double ax, double ay, double az)
        {
            double half = angleDegrees * Math.PI / 360.0;
            double s = Math.Sin(half);
            return new[] { ax * s, ay * s, az * s, Math.Cos(half) };
        }

        /// <summary>
        /// The paper's equations (1)-(2): a point at lon/lat (degrees) and elev (metres) in the
        /// Unity globe frame (Unity units) for Earth radius earthRadius (metres) and unityRadius (UR).
        /// </summary>
        public static double[] GlobePosition(double lonDeg, double latDeg, double elev, double earthRadius, double unityRadius)
        {
            double lon = lonDeg * Math.PI / 180.0, lat = latDeg * Math.PI / 180.0;
            double h = unityRadius + elev * unityRadius / earthRadius;
            return new[] { h * Math.Cos(lat) * Math.Sin(lon), h * Math.Sin(lat), -h * Math.Cos(lat) * Math.Cos(lon) };
        }

        /// <summary>
        /// The rotation taking local East/Up/North (x, y, z) at lon/lat (degrees) to the Unity globe
        /// frame: the matrix with columns East, Up, North, as a quaternion (x, y, z, w), w &gt;= 0.
        /// </summary>
        public static double[] EastUpNorthRotation(double lonDeg, double latDeg)
        {
            double lon = lonDeg * Math.PI / 180.0, lat = latDeg * Math.PI / 180.0;
            double sl = Math.Sin(lon), cl = Math.Cos(lon), sp = Math.Sin(lat), cp = Math.Cos(lat);
            // Columns: East (cl, 0, sl), Up (cp sl, sp, -cp cl), North (-sp sl, cp, sp cl).
            double m00 = cl, m01 = cp * sl, m02 = -sp * sl;
            double m10 = 0, m11 = sp, m12 = cp;
            double m20 = sl, m21 = -cp * cl, m22 = sp * cl;
            return QuaternionFromMatrix(m00, m01, m02, m10, m11, m12, m20, m21, m22);
        }

        /// <summary>Shepperd's method: the unit quaternion of a proper rotation matrix (row-major m_rc), w &gt;= 0.</summary>
        public static double[] QuaternionFromMatrix(double m00, double m01, double m02,
                                                    double m10, double m11, double m12,
                                                    double m20, double m21, double m22)
        {
            double x, y, z, w;
            double trace = m00 + m11 + m22;
            if (trace > 0)
            {
                double s = 2 * Math.Sqrt(1 + trace);
                w = s / 4; x = (m21 - m12) / s; y = (m02 - m20) / s; z = (m10 - m01) / s;
            }
            else if (m00 > m11 && m00 > m22)
            {
                double s = 2 * Math.Sqrt(1 + m00 - m11 - m22);
                w = (m21 - m12) / s; x = s / 4; y = (m01 + m10) / s; z = (m02 + m20) / s;
            }
            else if (m11 > m22)
            {
                double s = 2 * Math.Sqrt(1 + m11 - m00 - m22);
                w = (m02 - m20) / s; x = (m01 + m10) / s; y = s / 4; z = (m12 + m21) / s;
            }
            else
            {
                double s = 2 * Math.Sqrt(1 + m22 - m00 - m11);
                w = (m10 - m01) / s; x = (m02 + m20) / s; y = (m12 + m21) / s; z = s / 4;
            }
            if (w < 0) { x = -x; y = -y; z = -z; w = -w; }
            return new[] { x, y, z, w };
        }

        public override string ToString()
        {
            return string.Format(System.Globalization.CultureInfo.InvariantCulture,
                "position ({0:R}, {1:R}, {2:R}) rotation ({3:R}, {4:R}, {5:R}, {6:R}) scale {7:R}",
                px, py, pz, qx, qy, qz, qw, scale);
        }
    }
}
