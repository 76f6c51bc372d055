// A small strict JSON reader (RFC 8259) for reading lod_manifest.json outside Unity, where
// JsonUtility does not exist (tools, tests under mono). Inside Unity the package uses
// JsonUtility; both fill the same [Serializable] classes (see ManifestModel.cs).
//
// Data form: a JSON text becomes a tree of
//   object -> Dictionary<string, object> (keys in document order are not kept; duplicates are an error)
//   array  -> List<object>
//   string -> string, number -> double, true/false -> bool, null -> null.
using System;
using System.Collections.Generic;
using System.Globalization;
using System.Text;

namespace VWorldLod
{
    /// <summary>A JSON text that is not well formed: says where (line, column) and what.</summary>
    public class JsonSyntaxException : Exception
    {
        public readonly int Line;
        public readonly int Column;

        public JsonSyntaxException(int line, int column, string problem)
            : base("line " + line + ", column " + column + ": " + problem)
        {
            Line = line;
            Column = column;
        }
    }

    /// <summary>Parses a JSON text into Dictionary/List/string/double/bool/null.</summary>
    public static class PlainJson
    {
        // Deep enough for any manifest; guards the recursion against hostile input.
        const int MaxDepth = 64;

        /// <summary>The value of the whole text; throws JsonSyntaxException when malformed.</summary>
        public static object Parse(string text)
        {
            if (text == null) throw new ArgumentNullException("text");
            var reader = new Reader(text);
            reader.SkipWhitespace();
            object value = reader.ReadValue(0);
            reader.SkipWhitespace();
            if (!reader.AtEnd) throw reader.Error("unexpected text after the JSON value");
            return value;
        }

        sealed class Reader
        {
            readonly string s;
            int i;

            public Reader(string text) { s = text; }

            static bool IsDigit(char c) { return c >= '0' && c <= '9'; }

            public bool AtEnd { get { return i >= s.Length; } }

            public JsonSyntaxException Error(string problem)
            {
                int line = 1, column = 1;
                for (int k = 0; k < i && k < s.Length; k++)
                {
                    if (s[k] == '\n') { line++; column = 1; } else column++;
                }
                return new JsonSyntaxException(line, column, problem);
            }

            public void SkipWhitespace()
            {
                while (i < s.Length && (s[i] == ' ' || s[i] == '\t' || s[i] == '\n' || s[i] == '\r')) i++;
            }

            public object ReadValue(int depth)
            {
                if (depth > MaxDepth) throw Error("nesting deeper than " + MaxDepth);
                if (AtEnd) throw Error("unexpected end of text");
                char c = s[i];
                if (c == '{') return ReadObject(depth);
                if (c == '[') return ReadArray(depth);
                if (c == '"') return ReadString();
                if (c == '-' || (c >= '0' && c <= '9')) return ReadNumber();
                if (Match("true")) return true;
                if (Match("false")) return false;
                if (Match("null")) return null;
                throw Error("unexpected character '" + c + "'");
            }

            bool Match(string word)
            {
                if (string.CompareOrdinal(s, i, word, 0, word.Length) != 0) return false;
                i += word.Length;
                return true;
            }

            void Expect(char c)
            {
                if (AtEnd || s[i] != c) throw Error("expected '" + c + "'");
                i++;
            }

            Dictionary<string, object> ReadObject(int depth)
            {
                var result = new Dictionary<string, object>();
                Expect('{');
                SkipWhitespace();
                if (!AtEnd && s[i] == '}') { i++; return result; }
                while (true)
                {
                    SkipWhitespace();
                    if (AtEnd || s[i] != '"') throw Error("expected a string key");
                    string key = ReadString();
                    if (result.ContainsKey(key)) throw Error("duplicate key \"" + key + "\"");
                    SkipWhitespace();
                    Expect(':');
                    SkipWhitespace();
                    result[key] = ReadValue(depth + 1);
                    SkipWhitespace();
                    if (!AtEnd && s[i] == ',') { i++; continue; }
                    Expect('}');
                    return result;
                }
            }

            List<object> ReadArray(int depth)
            {
                var result = new List<object>();
                Expect('[');
                SkipWhitespace();
                if (!AtEnd && s[i] == ']') { i++; return result; }
                while (true)
                {
                    SkipWhitespace();
                    result.Add(ReadValue(depth + 1));
                    SkipWhitespace();
                    if (!AtEnd && s[i] == ',') { i++; continue; }
                    Expect(']');
                    return result;
                }
            }

            string ReadString()
            {
                Expect('"');
                var sb = new StringBuilder();
                while (true)
                {
                    if (AtEnd) throw Error("unterminated string");
                    char c = s[i++];
                    if (c == '"') return sb.ToString();
                    if (c < ' ') { i--; throw Error("control character in string"); }
                    if (c != '\\') { sb.Append(c); continue; }
                    if (AtEnd) throw Error("unterminated escape");
                    char e = s[i++];
                    switch (e)
                    {
                        case '"': sb.Append('"'); break;
                        case '\\': sb.Append('\\'); break;
                        case '/': sb.Append('/'); break;
                        case 'b': sb.Append('\b'); break;
                        case 'f': sb.Append('\f'); break;
                        case 'n': sb.Append('\n'); break;
                        case 'r': sb.Append('\r'); break;
                        case 't': sb.Append('\t'); break;
                        case 'u':
                            if (i + 4 > s.Length) throw Error("short \\u escape");
                            int code;
                            if (!int.TryParse(s.Substring(i, 4), NumberStyles.HexNumber, CultureInfo.InvariantCulture, out code))
                                throw Error("bad \\u escape");
                            sb.Append((char)code);
                            i += 4;
                            break;
                        default:
                            i--;
                            throw Error("unknown escape '\\" + e + "'");
                    }
                }
            }

            double ReadNumber()
            {
                int start = i;
                if (s[i] == '-') i++;
                if (AtEnd || !IsDigit(s[i])) throw Error("expected a digit");
                if (s[i] == '0') i++;
                else while (!AtEnd && IsDigit(s[i])) i++;
                if (!AtEnd && s[i] == '.')
                {
                    i++;
                    if (AtEnd || !IsDigit(s[i])) throw Error("expected a digit after '.'");
                    while (!AtEnd && IsDigit(s[i])) i++;
                }
                if (!AtEnd && (s[i] == 'e' || s[i] == 'E'))
                {
                    i++;
                    if (!AtEnd && (s[i] == '+' || s[i] == '-')) i++;
                    if (AtEnd || !IsDigit(s[i])) throw Error("expected a digit in the exponent");
                    while (!AtEnd && IsDigit(s[i])) i++;
                }
                return double.Parse(s.Substring(start, i - start), NumberStyles.Float, CultureInfo.InvariantCulture);
            }
        }
    }
}
