// A small, strict JSON reader for the shlight wire messages (plain C#, no UnityEngine, no
// reflection: safe under IL2CPP/UWP and .NET Standard 2.0).
//
// Objects become Dictionary<string, object>, arrays List<object>, numbers double, strings
// string, true/false bool, null null. Numbers are parsed with the invariant culture (a
// German-locale HoloLens must not read "0.5" as 5). Depth and size are bounded so that a
// hostile or broken peer cannot exhaust the stack.
using System;
using System.Collections.Generic;
using System.Globalization;
using System.Text;

namespace Shlight.Lighting
{
    /// <summary>Raised for text that is not valid JSON (message and character offset).</summary>
    public sealed class JsonFormatException : FormatException
    {
        public readonly int Position;

        public JsonFormatException(string message, int position)
            : base(message + " (at character " + position + ")")
        {
            Position = position;
        }
    }

    /// <summary>Minimal RFC 8259 JSON parser.</summary>
    public static class MiniJson
    {
        public const int MaxDepth = 64;
        public const int MaxLength = 4 * 1024 * 1024;

        /// <summary>Parse one JSON value; the whole text must be consumed (trailing space allowed).</summary>
        public static object Parse(string text)
        {
            if (text == null) throw new ArgumentNullException("text");
            if (text.Length > MaxLength) throw new JsonFormatException("JSON text too long", 0);
            var p = new Parser(text);
            p.SkipWhitespace();
            object value = p.ParseValue(0);
            p.SkipWhitespace();
            if (!p.AtEnd) throw new JsonFormatException("unexpected text after the JSON value", p.Pos);
            return value;
        }

        /// <summary>Parse and require a JSON object.</summary>
        public static Dictionary<string, object> ParseObject(string text)
        {
            var obj = Parse(text) as Dictionary<string, object>;
            if (obj == null) throw new JsonFormatException("expected a JSON object", 0);
            return obj;
        }

        /// <summary>Serialise a string as a JSON string literal (quotes and escapes).</summary>
        public static string Quote(string s)
        {
            var sb = new StringBuilder(s.Length + 2);
            sb.Append('"');
            foreach (char c in s)
            {
                switch (c)
                {
                    case '"': sb.Append("\\\""); break;
                    case '\\': sb.Append("\\\\"); break;
                    case '\n': sb.Append("\\n"); break;
                    case '\r': sb.Append("\\r"); break;
                    case '\t': sb.Append("\\t"); break;
                    case '\b': sb.Append("\\b"); break;
                    case '\f': sb.Append("\\f"); break;
                    default:
                        if (c < 0x20) sb.Append("\\u").Append(((int)c).ToString("x4", CultureInfo.InvariantCulture));
                        else sb.Append(c);
                        break;
                }
            }
            sb.Append('"');
            return sb.ToString();
        }

        /// <summary>Format a number the way JSON wants it (invariant culture, round-trip).</summary>
        public static string Number(double v)
        {
            if (double.IsNaN(v) || double.IsInfinity(v))
                throw new ArgumentException("JSON has no NaN or Infinity");
            return v.ToString("R", CultureInfo.InvariantCulture);
        }

        sealed class Parser
        {
            readonly string s;
            public int Pos;

            public Parser(string text) { s = text; Pos = 0; }

            public bool AtEnd { get { return Pos >= s.Length; } }

            public void SkipWhitespace()
            {
                while (Pos < s.Length)
                {
                    char c = s[Pos];
                    if (c == ' ' || c == '\t' || c == '\n' || c == '\r') Pos++;
                    else break;
                }
            }

            JsonFormatException Error(string what) { return new JsonFormatException(what, Pos); }

            public object ParseValue(int depth)
            {
                if (depth > MaxDepth) throw Error("JSON nested too deeply");
                if (AtEnd) throw Error("unexpected end of JSON");
                char c = s[Pos];
                switch (c)
                {
                    case '{': return ParseObject(depth + 1);
                    case '[': return ParseArray(depth + 1);
                    case '"': return ParseString();
                    case 't': Expect("true"); return true;
                    case 'f': Expect("false"); return false;
                    case 'n': Expect("null"); return null;
                    default:
                        if (c == '-' || (c >= '0' && c <= '9')) return ParseNumber();
                        throw Error("unexpected character '" + c + "'");
                }
            }

            void Expect(string word)
            {
                if (string.CompareOrdinal(s, Pos, word, 0, word.Length) != 0) throw Error("invalid literal");
                Pos += word.Length;
            }

            Dictionary<string, object> ParseObject(int depth)
            {
                var obj = new Dictionary<string, object>(StringComparer.Ordinal);
                Pos++; // '{'
                SkipWhitespace();
                if (!AtEnd && s[Pos] == '}') { Pos++; return obj; }
                while (true)
                {
                    SkipWhitespace();
                    if (AtEnd || s[Pos] != '"') throw Error("expected a string key");
                    string key = ParseString();
                    SkipWhitespace();
                    if (AtEnd || s[Pos] != ':') throw Error("expected ':'");
                    Pos++;
                    SkipWhitespace();
                    obj[key] = ParseValue(depth); // a repeated key keeps the last value
                    SkipWhitespace();
                    if (AtEnd) throw Error("unterminated object");
                    char c = s[Pos++];
                    if (c == '}') return obj;
                    if (c != ',') { Pos--; throw Error("expected ',' or '}'"); }
                }
            }

            List<object> ParseArray(int depth)
            {
                var list = new List<object>();
                Pos++; // '['
                SkipWhitespace();
                if (!AtEnd && s[Pos] == ']') { Pos++; return list; }
                while (true)
                {
                    SkipWhitespace();
                    list.Add(ParseValue(depth));
                    SkipWhitespace();
                    if (AtEnd) throw Error("unterminated array");
                    char c = s[Pos++];
                    if (c == ']') return list;
                    if (c != ',') { Pos--; throw Error("expected ',' or ']'"); }
                }
            }

            string ParseString()
            {
                Pos++; // opening quote
                StringBuilder sb = null;
                int start = Pos;
                while (true)
                {
                    if (AtEnd) throw Error("unterminated string");
                    char c = s[Pos];
                    if (c == '"')
                    {
                        string result = sb == null ? s.Substring(start, Pos - start)
                                                   : sb.Append(s, start, Pos - start).ToString();
                        Pos++;
                        return result;
                    }
                    if (c < 0x20) throw Error("control character in string");
                    if (c != '\\') { Pos++; continue; }
                    if (sb == null) sb = new StringBuilder();
                    sb.Append(s, start, Pos - start);
                    Pos++;
                    if (AtEnd) throw Error("unterminated escape");
                    char e = s[Pos++];
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
                            if (Pos + 4 > s.Length) throw Error("short \\u escape");
                            int code;
                            if (!int.TryParse(s.Substring(Pos, 4), NumberStyles.AllowHexSpecifier,
                                              CultureInfo.InvariantCulture, out code))
                                throw Error("bad \\u escape");
                            sb.Append((char)code);
                            Pos += 4;
                            break;
                        default: Pos--; throw Error("bad escape");
                    }
                    start = Pos;
                }
            }

            double ParseNumber()
            {
                int start = Pos;
                if (s[Pos] == '-') Pos++;
                if (AtEnd) throw Error("bad number");
                if (s[Pos] == '0') Pos++;
                else if (s[Pos] >= '1' && s[Pos] <= '9') { while (!AtEnd && s[Pos] >= '0' && s[Pos] <= '9') Pos++; }
                else throw Error("bad number");
                if (!AtEnd && s[Pos] == '.')
                {
                    Pos++;
                    int digits = Pos;
                    while (!AtEnd && s[Pos] >= '0' && s[Pos] <= '9') Pos++;
                    if (Pos == digits) throw Error("bad fraction");
                }
                if (!AtEnd && (s[Pos] == 'e' || s[Pos] == 'E'))
                {
                    Pos++;
                    if (!AtEnd && (s[Pos] == '+' || s[Pos] == '-')) Pos++;
                    int digits = Pos;
                    while (!AtEnd && s[Pos] >= '0' && s[Pos] <= '9') Pos++;
                    if (Pos == digits) throw Error("bad exponent");
                }
                double v;
                if (!double.TryParse(s.Substring(start, Pos - start), NumberStyles.Float,
                                     CultureInfo.InvariantCulture, out v)
                    || double.IsInfinity(v) || double.IsNaN(v))
                {
                    Pos = start;
                    throw Error("number out of range");
                }
                return v;
            }
        }
    }
}
