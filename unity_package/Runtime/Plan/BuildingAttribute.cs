// One source attribute of a building (the manifest's buildings[].attributes, docs/input.md
// "Attributes"), as Unity can serialize it: name, value as text, and the JSON type it had.
using System;

namespace VWorldLod
{
    [Serializable]
    public class BuildingAttribute
    {
        /// <summary>The attribute's name as in the manifest (e.g. "year_of_construction", "address.city").</summary>
        public string name;
        /// <summary>Its value as text: strings as they are, numbers in invariant culture (integers without ".0"), booleans "true"/"false".</summary>
        public string value;
        /// <summary>"string", "number" or "boolean" (the manifest's JSON type).</summary>
        public string type;

        public BuildingAttribute() { }

        public BuildingAttribute(string name, string value, string type)
        {
            this.name = name;
            this.value = value;
            this.type = type;
        }
    }
}
