// A building's identity and source attributes on its GameObject (the prefab's root from the
// Editor import, the streamed building's root at run time): shown in the Inspector, read from
// scripts with Get / TryGet. Filled from the manifest (buildings[].id, source, attributes).
using System.Collections.Generic;
using UnityEngine;

namespace VWorldLod
{
    public class BuildingAttributes : MonoBehaviour
    {
        /// <summary>The building's id in the export (manifest buildings[].id).</summary>
        public string buildingId;
        /// <summary>The file it was read from (manifest buildings[].source).</summary>
        public string source;
        /// <summary>Its source attributes, by name (docs/input.md "Attributes").</summary>
        public List<BuildingAttribute> attributes = new List<BuildingAttribute>();

        /// <summary>The value (as text) of the attribute name, or null when the building has none.</summary>
        public string Get(string name)
        {
            string value;
            return TryGet(name, out value) ? value : null;
        }

        /// <summary>True with the value (as text) when the building has the attribute name.</summary>
        public bool TryGet(string name, out string value)
        {
            foreach (BuildingAttribute attribute in attributes)
            {
                if (attribute.name == name)
                {
                    value = attribute.value;
                    return true;
                }
            }
            value = null;
            return false;
        }

        /// <summary>The component on root (added once, refilled on every call) holding building's id, source and attributes.</summary>
        public static BuildingAttributes Attach(GameObject root, BuildingPlan building)
        {
            BuildingAttributes component = root.GetComponent<BuildingAttributes>();
            if (component == null) component = root.AddComponent<BuildingAttributes>();
            component.buildingId = building.Id;
            component.source = building.Source;
            component.attributes = new List<BuildingAttribute>(building.Attributes ?? new BuildingAttribute[0]);
            return component;
        }
    }
}
