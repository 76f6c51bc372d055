// Which building a vertex or triangle of a tile proxy belongs to, from the proxy's record
// (OUT/tileset_proxies/<tile>.json, written beside its .glb by exporter/tileset/proxy.py):
// "buildings" lists the buildings merged in it ("<tile>/<building id>"), "owners" is the per-vertex
// index into that list, run-length coded in the glb's vertex order ([[building index, vertex
// count], ...]: proxy.py owner_runs). The glb's EXT_mesh_features _FEATURE_ID_0 holds the same
// ids, but glTFast does not load feature ids; it keeps a single primitive's vertex order (positions
// converted one by one, x negated: Jobs.cs ConvertPositions*; vertices of primitive i written at
// VertexBufferGenerator.VertexIntervals[i]) and each triangle's first index (the winding is
// reversed as (a, c, b): Jobs.cs ConvertIndices*FlippedJob), so the record's order is the Unity
// mesh's order and Mesh.triangles[3 t] is the first vertex of the glb's triangle t. The record's
// "values" (per building: property id -> [name, value], the glb's property table row) give each
// building's id, source_id, source_file, height and source attributes.
using System;
using System.Collections.Generic;

namespace VWorldLod
{
    public sealed class ProxyFeatures
    {
        /// <summary>The buildings merged in the proxy, "&lt;tile&gt;/&lt;building id&gt;", in the record's order.</summary>
        public readonly string[] Buildings;
        /// <summary>Per building (Buildings' order): its metadata values by name (in name order; empty when the record has none).</summary>
        public readonly BuildingAttribute[][] Values;
        /// <summary>The number of vertices the runs cover (the proxy mesh's vertex count).</summary>
        public readonly int VertexCount;

        // Run r covers vertices [runStart[r], runStart[r + 1]) and belongs to Buildings[runOwner[r]].
        readonly int[] runStart;
        readonly int[] runOwner;

        ProxyFeatures(string[] buildings, BuildingAttribute[][] values, int[] runStart, int[] runOwner)
        {
            Buildings = buildings;
            Values = values;
            this.runStart = runStart;
            this.runOwner = runOwner;
            VertexCount = runStart[runStart.Length - 1];
        }

        /// <summary>The record's path beside the proxy's .glb path ("tileset_proxies/x.glb" -> "tileset_proxies/x.json").</summary>
        public static string RecordPath(string glbPath)
        {
            return glbPath.EndsWith(".glb", StringComparison.OrdinalIgnoreCase) ? glbPath.Substring(0, glbPath.Length - 4) + ".json" : glbPath + ".json";
        }

        /// <summary>
        /// The owners of a proxy record's text (recordName names it in errors) for a mesh of
        /// vertexCount vertices. ManifestException when the text is not such a record, an owner
        /// is not a building of its list, or the runs do not cover exactly vertexCount vertices.
        /// </summary>
        public static ProxyFeatures Parse(string recordJson, string recordName, int vertexCount)
        {
            object tree;
            try
            {
                tree = PlainJson.Parse(recordJson);
            }
            catch (JsonSyntaxException e)
            {
                throw new ManifestException(recordName, null, "not JSON: " + e.Message);
            }
            var top = tree as Dictionary<string, object>;
            if (top == null) throw new ManifestException(recordName, null, "not a JSON object");
            string[] buildings = BuildingList(recordName, top);
            object found;
            if (!top.TryGetValue("owners", out found) || !(found is List<object>))
                throw new ManifestException(recordName, "owners", "missing or not a list of [building index, vertex count] runs");
            var runs = (List<object>)found;
            var starts = new int[runs.Count + 1];
            var owners = new int[runs.Count];
            long covered = 0;
            for (int r = 0; r < runs.Count; r++)
            {
                var run = runs[r] as List<object>;
                string field = "owners[" + r + "]";
                if (run == null || run.Count != 2 || !IsCount(run[0]) || !IsCount(run[1]))
                    throw new ManifestException(recordName, field, "not a [building index, vertex count] pair of non-negative integers");
                double owner = (double)run[0], count = (double)run[1];
                if (owner >= buildings.Length)
                    throw new ManifestException(recordName, field, "building index " + owner + " is not in buildings (" + buildings.Length + " of them)");
                owners[r] = (int)owner;
                starts[r] = (int)Math.Min(covered, int.MaxValue);
                covered += (long)count;
            }
            if (covered != vertexCount)
                throw new ManifestException(recordName, "owners", "the runs cover " + covered + " vertices, the proxy mesh has " + vertexCount);
            starts[runs.Count] = vertexCount;
            return new ProxyFeatures(buildings, ValueLists(recordName, top, buildings.Length), starts, owners);
        }

        /// <summary>The building ("&lt;tile&gt;/&lt;building id&gt;") that vertex vertexIndex came from.</summary>
        public string BuildingAt(int vertexIndex)
        {
            return Buildings[OwnerAt(vertexIndex)];
        }

        /// <summary>The index in Buildings (and Values) of the building that vertex vertexIndex came from.</summary>
        public int OwnerAt(int vertexIndex)
        {
            if (vertexIndex < 0 || vertexIndex >= VertexCount)
                throw new ArgumentOutOfRangeException("vertexIndex", vertexIndex, "the proxy has " + VertexCount + " vertices");
            // The last run starting at or before vertexIndex (runs of zero vertices are skipped by the search).
            int lo = 0, hi = runOwner.Length - 1;
            while (lo < hi)
            {
                int mid = (lo + hi + 1) / 2;
                if (runStart[mid] <= vertexIndex) lo = mid;
                else hi = mid - 1;
            }
            return runOwner[lo];
        }

        /// <summary>
        /// The building of triangle triangleIndex of triangles (a Unity mesh's index list, three
        /// per triangle, e.g. Mesh.triangles; RaycastHit.triangleIndex indexes it): its first vertex's.
        /// </summary>
        public string BuildingOfTriangle(int[] triangles, int triangleIndex)
        {
            if (triangleIndex < 0 || 3 * (long)triangleIndex + 2 >= triangles.Length)
                throw new ArgumentOutOfRangeException("triangleIndex", triangleIndex, "the mesh has " + triangles.Length / 3 + " triangles");
            return BuildingAt(triangles[3 * triangleIndex]);
        }

        /// <summary>A building key "&lt;tile&gt;/&lt;building id&gt;" split at its first '/' (tile names have none).</summary>
        public static void Split(string key, out string tile, out string buildingId)
        {
            int slash = key.IndexOf('/');
            tile = slash < 0 ? "" : key.Substring(0, slash);
            buildingId = slash < 0 ? key : key.Substring(slash + 1);
        }

        static string[] BuildingList(string recordName, Dictionary<string, object> top)
        {
            object found;
            if (!top.TryGetValue("buildings", out found) || !(found is List<object>))
                throw new ManifestException(recordName, "buildings", "missing or not a list of building keys");
            var list = (List<object>)found;
            var buildings = new string[list.Count];
            for (int i = 0; i < list.Count; i++)
            {
                buildings[i] = list[i] as string;
                if (buildings[i] == null) throw new ManifestException(recordName, "buildings[" + i + "]", "not a string");
            }
            return buildings;
        }

        // The record's "values" (absent in records before issue 38: no values), one list per building.
        static BuildingAttribute[][] ValueLists(string recordName, Dictionary<string, object> top, int count)
        {
            var result = new BuildingAttribute[count][];
            object found;
            var list = top.TryGetValue("values", out found) ? found as List<object> : null;
            if (list != null && list.Count != count)
                throw new ManifestException(recordName, "values", list.Count + " entries for " + count + " buildings");
            for (int b = 0; b < count; b++)
            {
                var values = new List<BuildingAttribute>();
                var item = list != null ? list[b] as Dictionary<string, object> : null;
                if (item != null)
                    foreach (var pair in item)
                    {
                        var named = pair.Value as List<object>;
                        if (named == null || named.Count != 2 || !(named[0] is string)) continue;
                        BuildingAttribute attribute = AttributeReader.Attribute((string)named[0], named[1]);
                        if (attribute != null) values.Add(attribute);
                    }
                values.Sort((x, y) => string.CompareOrdinal(x.name, y.name));
                result[b] = values.ToArray();
            }
            return result;
        }

        static bool IsCount(object value)
        {
            if (!(value is double)) return false;
            double v = (double)value;
            return v >= 0 && v <= int.MaxValue && Math.Floor(v) == v;
        }
    }
}
