// The buildings' attributes of a manifest text. JsonUtility cannot read an object with
// variable keys (buildings[].attributes), so they are read here with PlainJson, once per
// manifest, and attached to the plan's buildings (LodPlanner.Load, RuntimeTile).
using System;
using System.Collections.Generic;
using System.Globalization;

namespace VWorldLod
{
    public static class AttributeReader
    {
        /// <summary>
        /// Building id -> its attributes in name order, for every building of the manifest text
        /// that has some. A text that is not JSON, or a building without an id, gives nothing
        /// (the manifest's own parser reports what is wrong with it).
        /// </summary>
        public static Dictionary<string, BuildingAttribute[]> Read(string manifestJson)
        {
            var result = new Dictionary<string, BuildingAttribute[]>();
            object tree;
            try
            {
                tree = PlainJson.Parse(manifestJson);
            }
            catch (JsonSyntaxException)
            {
                return result;
            }
            var top = tree as Dictionary<string, object>;
            object buildings;
            if (top == null || !top.TryGetValue("buildings", out buildings) || !(buildings is List<object>)) return result;
            foreach (object item in (List<object>)buildings)
            {
                var building = item as Dictionary<string, object>;
                object id, attributes;
                if (building == null || !building.TryGetValue("id", out id) || !(id is string)) continue;
                if (!building.TryGetValue("attributes", out attributes) || !(attributes is Dictionary<string, object>)) continue;
                var list = new List<BuildingAttribute>();
                foreach (var pair in (Dictionary<string, object>)attributes)
                {
                    BuildingAttribute attribute = Attribute(pair.Key, pair.Value);
                    if (attribute != null) list.Add(attribute);
                }
                list.Sort((a, b) => string.CompareOrdinal(a.name, b.name));
                result[(string)id] = list.ToArray();
            }
            return result;
        }

        /// <summary>Sets Attributes on every building of plan found in the manifest text; returns plan.</summary>
        public static TilePlan Attach(TilePlan plan, string manifestJson)
        {
            Dictionary<string, BuildingAttribute[]> found = Read(manifestJson);
            foreach (BuildingPlan building in plan.Buildings)
            {
                BuildingAttribute[] attributes;
                if (building.Id != null && found.TryGetValue(building.Id, out attributes)) building.Attributes = attributes;
            }
            return plan;
        }

        /// <summary>name's JSON value as a BuildingAttribute; null for null, objects and arrays.</summary>
        internal static BuildingAttribute Attribute(string name, object value)
        {
            if (value is string) return new BuildingAttribute(name, (string)value, "string");
            if (value is bool) return new BuildingAttribute(name, (bool)value ? "true" : "false", "boolean");
            if (value is double)
            {
                double number = (double)value;
                string text = Math.Floor(number) == number && Math.Abs(number) < 9007199254740992.0
                    ? ((long)number).ToString(CultureInfo.InvariantCulture)
                    : number.ToString("R", CultureInfo.InvariantCulture);
                return new BuildingAttribute(name, text, "number");
            }
            return null; // null, objects, arrays: not written by the exporter (docs/input.md)
        }
    }
}
