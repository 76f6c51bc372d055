// Turning manifest text into TileManifest. Inside Unity the package uses JsonUtility
// (JsonUtilityManifestParser in Runtime/Unity); everywhere else PlainJsonManifestParser, which
// follows JsonUtility's rules on the same classes: public fields named like the JSON keys,
// unknown keys ignored, missing class fields and arrays created empty, missing numbers 0.
// Unlike JsonUtility it rejects a value of the wrong type instead of skipping it.
using System;
using System.Collections;
using System.Collections.Generic;
using System.Globalization;
using System.Reflection;

namespace VWorldLod
{
    /// <summary>Parses manifest text; throws ManifestException naming manifestPath when it cannot.</summary>
    public interface IManifestParser
    {
        TileManifest Parse(string json, string manifestPath);
    }

    /// <summary>The parser for use outside Unity (and in the package's tests).</summary>
    public class PlainJsonManifestParser : IManifestParser
    {
        public TileManifest Parse(string json, string manifestPath)
        {
            return ParseAs<TileManifest>(json, manifestPath);
        }

        /// <summary>Any [Serializable] class of this package (the manifest, the tile index) from JSON text.</summary>
        public static T ParseAs<T>(string json, string manifestPath) where T : class
        {
            object tree;
            try
            {
                tree = PlainJson.Parse(json);
            }
            catch (JsonSyntaxException e)
            {
                throw new ManifestException(manifestPath, "", "not valid JSON: " + e.Message, e);
            }
            if (!(tree is Dictionary<string, object>))
                throw new ManifestException(manifestPath, "", "the top level is not a JSON object");
            return (T)Fill(typeof(T), tree, "", manifestPath);
        }

        static object Fill(Type type, object value, string field, string manifestPath)
        {
            if (type == typeof(string))
            {
                if (value == null) return null;
                if (value is string) return value;
                throw Wrong(manifestPath, field, "a string", value);
            }
            if (type == typeof(bool))
            {
                if (value is bool) return value;
                throw Wrong(manifestPath, field, "true or false", value);
            }
            if (type == typeof(double) || type == typeof(float) || type == typeof(int) || type == typeof(long))
                return Number(type, value, field, manifestPath);
            if (type.IsArray)
            {
                var list = value as List<object>;
                if (list == null) throw Wrong(manifestPath, field, "an array", value);
                Type element = type.GetElementType();
                Array array = Array.CreateInstance(element, list.Count);
                for (int k = 0; k < list.Count; k++)
                    array.SetValue(Fill(element, list[k], field + "[" + k + "]", manifestPath), k);
                return array;
            }
            var members = value as Dictionary<string, object>;
            if (members == null) throw Wrong(manifestPath, field, "an object", value);
            object instance = Activator.CreateInstance(type);
            foreach (FieldInfo info in type.GetFields(BindingFlags.Public | BindingFlags.Instance))
            {
                string path = field.Length == 0 ? info.Name : field + "." + info.Name;
                object member;
                if (members.TryGetValue(info.Name, out member) && member != null)
                    info.SetValue(instance, Fill(info.FieldType, member, path, manifestPath));
                else if (info.FieldType.IsArray || (info.FieldType.IsClass && info.FieldType != typeof(string)))
                    info.SetValue(instance, NewDefault(info.FieldType));
            }
            return instance;
        }

        // What JsonUtility leaves in a missing field: an empty array, or an instance whose own
        // class and array fields are filled the same way (the manifest classes are not recursive).
        static object NewDefault(Type type)
        {
            if (type.IsArray) return Array.CreateInstance(type.GetElementType(), 0);
            object instance = Activator.CreateInstance(type);
            foreach (FieldInfo info in type.GetFields(BindingFlags.Public | BindingFlags.Instance))
                if (info.FieldType.IsArray || (info.FieldType.IsClass && info.FieldType != typeof(string)))
                    info.SetValue(instance, NewDefault(info.FieldType));
            return instance;
        }

        static object Number(Type type, object value, string field, string manifestPath)
        {
            if (!(value is double)) throw Wrong(manifestPath, field, "a number", value);
            double d = (double)value;
            if (type == typeof(double)) return d;
            if (type == typeof(float)) return (float)d;
            if (d != Math.Floor(d)) throw Wrong(manifestPath, field, "an integer", value);
            if (type == typeof(int))
            {
                if (d < int.MinValue || d > int.MaxValue) throw Wrong(manifestPath, field, "a 32-bit integer", value);
                return (int)d;
            }
            if (d < long.MinValue || d > long.MaxValue) throw Wrong(manifestPath, field, "a 64-bit integer", value);
            return (long)d;
        }

        static ManifestException Wrong(string manifestPath, string field, string expected, object value)
        {
            return new ManifestException(manifestPath, field, "expected " + expected + ", found " + Describe(value));
        }

        static string Describe(object value)
        {
            if (value == null) return "null";
            if (value is string) return "the string \"" + value + "\"";
            if (value is bool) return ((bool)value) ? "true" : "false";
            if (value is double) return ((double)value).ToString("R", CultureInfo.InvariantCulture);
            if (value is IList) return "an array";
            return "an object";
        }
    }
}
