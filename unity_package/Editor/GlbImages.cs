// The images embedded in a binary glTF (.glb), read without Unity: what the Editor import writes
// out as separate image files so that Unity's TextureImporter compresses them per platform
// (glTFast stores embedded images as uncompressed RGBA32 sub-assets with no TextureImporter).
//
// GLB layout (glTF 2.0 spec, "Binary glTF Layout"): a 12-byte header (magic "glTF", version 2,
// total length), then chunks of (uint32 length, uint32 type, data): first JSON ("JSON"), then an
// optional binary buffer ("BIN\0"). An image with a bufferView has its encoded bytes at
// BIN[byteOffset .. byteOffset + byteLength] of that view (buffer 0 = the BIN chunk). Left out:
// images by URI (glTFast already loads those as the project's own texture assets), KTX2 images and
// the JPEG/PNG fallbacks of KHR_texture_basisu textures (an export with textures.ktx2: glTFast
// loads the KTX2 image with com.unity.cloud.ktx, which transcodes it to a compressed GPU format).
//
// Names: glTFast names the Texture2D it makes for image i `image.name`, or "image_<i>" when the
// name is empty (GltfImport.GetImageName, glTFast 6.3 to 6.15); GlbImage.TextureName follows it so
// the Editor import can find glTFast's texture in a material and swap in the compressed one.
using System;
using System.Collections.Generic;
using System.IO;
using System.Text;

namespace VWorldLod.EditorTools
{
    /// <summary>One embedded image: its index in the glTF, glTFast's texture name, MIME type, encoded bytes.</summary>
    public class GlbImage
    {
        public int Index;
        public string TextureName;
        public string MimeType;
        public byte[] Data;

        /// <summary>".jpg" or ".png" (the only image types the exporter writes and glTF core allows).</summary>
        public string Extension { get { return MimeType == "image/png" ? ".png" : ".jpg"; } }
    }

    public static class GlbImages
    {
        const uint Magic = 0x46546C67; // "glTF"
        const uint JsonChunk = 0x4E4F534A; // "JSON"
        const uint BinChunk = 0x004E4942; // "BIN\0"

        /// <summary>The embedded images of the .glb at path; a file that is not a valid GLB raises InvalidDataException naming it.</summary>
        public static List<GlbImage> Read(string path)
        {
            try
            {
                return Parse(File.ReadAllBytes(path));
            }
            catch (InvalidDataException e)
            {
                throw new InvalidDataException(path + ": " + e.Message);
            }
        }

        /// <summary>The embedded images of a GLB's bytes.</summary>
        public static List<GlbImage> Parse(byte[] glb)
        {
            if (glb.Length < 20 || BitConverter.ToUInt32(glb, 0) != Magic) throw new InvalidDataException("not a binary glTF (no 'glTF' header)");
            if (BitConverter.ToUInt32(glb, 4) != 2) throw new InvalidDataException("glTF container version " + BitConverter.ToUInt32(glb, 4) + ", expected 2");
            long total = Math.Min(BitConverter.ToUInt32(glb, 8), (uint)glb.Length);
            string json = null;
            long binStart = -1, binLength = 0;
            long at = 12;
            while (at + 8 <= total)
            {
                long length = BitConverter.ToUInt32(glb, (int)at);
                uint type = BitConverter.ToUInt32(glb, (int)at + 4);
                long start = at + 8;
                if (start + length > total) throw new InvalidDataException("chunk at byte " + at + " runs past the end of the file");
                if (type == JsonChunk && json == null) json = Encoding.UTF8.GetString(glb, (int)start, (int)length);
                else if (type == BinChunk && binStart < 0) { binStart = start; binLength = length; }
                at = start + length;
            }
            if (json == null) throw new InvalidDataException("no JSON chunk");
            Dictionary<string, object> root;
            try
            {
                root = PlainJson.Parse(json) as Dictionary<string, object>;
            }
            catch (JsonSyntaxException e)
            {
                throw new InvalidDataException("JSON chunk: " + e.Message);
            }
            if (root == null) throw new InvalidDataException("JSON chunk is not an object");
            var images = List(root, "images");
            var views = List(root, "bufferViews");
            var fallbacks = BasisuFallbacks(root);
            var result = new List<GlbImage>();
            for (int i = 0; i < images.Count; i++)
            {
                var image = images[i] as Dictionary<string, object>;
                if (image == null || !image.ContainsKey("bufferView") || fallbacks.Contains(i)) continue;
                int view = Int(image["bufferView"], "images[" + i + "].bufferView");
                if (view < 0 || view >= views.Count) throw new InvalidDataException("images[" + i + "].bufferView " + view + " does not exist");
                var v = (Dictionary<string, object>)views[view];
                long offset = v.ContainsKey("byteOffset") ? Int(v["byteOffset"], "bufferViews[" + view + "].byteOffset") : 0;
                long length = Int(v["byteLength"], "bufferViews[" + view + "].byteLength");
                if (binStart < 0 || offset + length > binLength) throw new InvalidDataException("images[" + i + "]: its bytes lie outside the BIN chunk");
                var data = new byte[length];
                Array.Copy(glb, binStart + offset, data, 0, length);
                object name, mime;
                image.TryGetValue("name", out name);
                image.TryGetValue("mimeType", out mime);
                string type = mime as string ?? ImageHeader.Sniff(data);
                if (type != "image/jpeg" && type != "image/png") continue; // KTX2 (or unknown): not for TextureImporter
                result.Add(new GlbImage
                {
                    Index = i,
                    TextureName = string.IsNullOrEmpty(name as string) ? "image_" + i : (string)name,
                    MimeType = type,
                    Data = data,
                });
            }
            return result;
        }

        // The "source" images of textures that have a KHR_texture_basisu image.
        static HashSet<int> BasisuFallbacks(Dictionary<string, object> root)
        {
            var result = new HashSet<int>();
            foreach (object item in List(root, "textures"))
            {
                var texture = item as Dictionary<string, object>;
                object extensions, source;
                if (texture != null && texture.TryGetValue("extensions", out extensions)
                    && extensions is Dictionary<string, object> && ((Dictionary<string, object>)extensions).ContainsKey("KHR_texture_basisu")
                    && texture.TryGetValue("source", out source) && source is double)
                    result.Add((int)(double)source);
            }
            return result;
        }

        static List<object> List(Dictionary<string, object> root, string key)
        {
            object value;
            return root.TryGetValue(key, out value) && value is List<object> ? (List<object>)value : new List<object>();
        }

        static int Int(object value, string field)
        {
            if (!(value is double) || (double)value < 0 || (double)value > int.MaxValue || Math.Floor((double)value) != (double)value)
                throw new InvalidDataException(field + " is not a non-negative integer");
            return (int)(double)value;
        }
    }
}
