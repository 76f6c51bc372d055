// Import settings for the building textures the Editor import writes out (TextureImportPostprocessor
// applies them to Unity's TextureImporter), and the GPU bytes those settings give: plain C#, so
// the same rules are tested and measured under mono (tests/test_unity_package.py).
//
// Per platform (Unity's platform names for TextureImporter.SetPlatformTextureSettings):
//   Standalone  opaque DXT1 (BC1, 4 bits/pixel), with alpha BC7 (8 bits/pixel)
//   Android, iPhone  ASTC 6x6 (128 bits per 6x6 block, 3.56 bits/pixel), alpha or not
//   WebGL       opaque DXT1, with alpha DXT5 (8 bits/pixel): the S3TC formats desktop browsers
//               expose (WEBGL_compressed_texture_s3tc); a browser without them gets the texture
//               decompressed to RGBA32 by Unity at load time
// Everything: sRGB colour, mipmaps (box filter, Unity's default) down to 1x1, mipmap streaming
// (Unity loads only the mips a camera needs when Quality Settings' Texture Streaming is on), no
// power-of-two rescale (the exporter's sizes are multiples of 4, which block compression needs),
// repeat wrap and trilinear filtering (the exporter's glTF sampler: REPEAT, LINEAR_MIPMAP_LINEAR),
// not readable from scripts (no CPU copy), and a max size that keeps the size the exporter gave the
// level (the exporter already halves each level's atlas per side; Unity's default max size, 2048,
// would shrink a bigger LOD0 atlas).
//
// GPU bytes: every mip level of a w x h texture, halved per side down to 1 x 1, takes
// ceil(w / bw) * ceil(h / bh) blocks of the format's block bytes (Unity manual, "Texture
// formats": RGBA32 4 bytes/pixel, DXT1 0.5, DXT5 and BC7 1, ASTC 6x6 16 bytes per 6x6 block).
// Today's figure (glTFast's embedded textures: RGBA32 with a full mip chain, see
// Documentation~/textures.md) is RGBA32 through the same sum.
using System;
using System.Collections.Generic;

namespace VWorldLod.EditorTools
{
    /// <summary>The GPU formats the rules use, with their block geometry.</summary>
    public enum GpuFormat
    {
        RGBA32,
        DXT1,
        DXT5,
        BC7,
        ASTC_6x6,
    }

    /// <summary>One platform's override: Unity's platform name and the format.</summary>
    public struct PlatformFormat
    {
        public string Platform;
        public GpuFormat Format;
    }

    /// <summary>Every TextureImporter setting the package applies to one building texture.</summary>
    public class TextureImportPlan
    {
        public bool SRgb = true;
        public bool Mipmaps = true;
        public bool StreamingMipmaps = true;
        public bool AlphaFromInput;
        public int MaxSize;
        public PlatformFormat[] Platforms;
    }

    public static class TextureImportRules
    {
        /// <summary>Unity's platform names the rules override, in table order.</summary>
        public static readonly string[] PlatformNames = { "Standalone", "Android", "iPhone", "WebGL" };

        /// <summary>The format for platform ("Standalone", "Android", "iPhone", "WebGL") of an opaque or alpha texture.</summary>
        public static GpuFormat FormatFor(string platform, bool hasAlpha)
        {
            switch (platform)
            {
                case "Standalone": return hasAlpha ? GpuFormat.BC7 : GpuFormat.DXT1;
                case "Android":
                case "iPhone": return GpuFormat.ASTC_6x6;
                case "WebGL": return hasAlpha ? GpuFormat.DXT5 : GpuFormat.DXT1;
                default: throw new ArgumentException("no texture rule for platform " + platform);
            }
        }

        /// <summary>The settings of a texture of that size (pixels) and alpha.</summary>
        public static TextureImportPlan PlanFor(ImageInfo image)
        {
            var platforms = new PlatformFormat[PlatformNames.Length];
            for (int i = 0; i < platforms.Length; i++)
                platforms[i] = new PlatformFormat { Platform = PlatformNames[i], Format = FormatFor(PlatformNames[i], image.HasAlpha) };
            return new TextureImportPlan
            {
                AlphaFromInput = image.HasAlpha,
                MaxSize = MaxSizeFor(Math.Max(image.Width, image.Height)),
                Platforms = platforms,
            };
        }

        /// <summary>What the settings of PlanFor(image) depend on, as recorded in the importer's userData.</summary>
        public static string MadeFor(ImageInfo image)
        {
            return "vworldlod-texture " + image.Width + "x" + image.Height + (image.HasAlpha ? " alpha" : "");
        }

        /// <summary>The smallest of Unity's max sizes (32 .. 16384, powers of two) not below side (pixels).</summary>
        public static int MaxSizeFor(int side)
        {
            int size = 32;
            while (size < side && size < 16384) size *= 2;
            return size;
        }

        /// <summary>(block width, block height, bytes per block) of a format.</summary>
        public static int[] Block(GpuFormat format)
        {
            switch (format)
            {
                case GpuFormat.RGBA32: return new[] { 1, 1, 4 };
                case GpuFormat.DXT1: return new[] { 4, 4, 8 };
                case GpuFormat.DXT5: return new[] { 4, 4, 16 };
                case GpuFormat.BC7: return new[] { 4, 4, 16 };
                case GpuFormat.ASTC_6x6: return new[] { 6, 6, 16 };
                default: throw new ArgumentException("unknown format " + format);
            }
        }

        /// <summary>GPU bytes of a width x height texture in format, with its full mip chain when mipmaps.</summary>
        public static long GpuBytes(int width, int height, GpuFormat format, bool mipmaps)
        {
            int[] b = Block(format);
            long total = 0;
            int w = width, h = height;
            while (true)
            {
                total += (long)((w + b[0] - 1) / b[0]) * ((h + b[1] - 1) / b[1]) * b[2];
                if (!mipmaps || (w == 1 && h == 1)) return total;
                w = Math.Max(1, w / 2);
                h = Math.Max(1, h / 2);
            }
        }

        /// <summary>GPU bytes of image with the package's settings on platform (its max size never shrinks it).</summary>
        public static long ImportedBytes(ImageInfo image, string platform)
        {
            return GpuBytes(image.Width, image.Height, FormatFor(platform, image.HasAlpha), true);
        }

        /// <summary>GPU bytes of image as glTFast embeds it today: RGBA32 with mipmaps.</summary>
        public static long EmbeddedBytes(ImageInfo image)
        {
            return GpuBytes(image.Width, image.Height, GpuFormat.RGBA32, true);
        }

        /// <summary>Total GPU bytes of images: today's (key "embedded RGBA32") and per platform.</summary>
        public static Dictionary<string, long> Totals(IEnumerable<ImageInfo> images)
        {
            var totals = new Dictionary<string, long> { { "embedded RGBA32", 0 } };
            foreach (string p in PlatformNames) totals[p] = 0;
            foreach (ImageInfo image in images)
            {
                totals["embedded RGBA32"] += EmbeddedBytes(image);
                foreach (string p in PlatformNames) totals[p] += ImportedBytes(image, p);
            }
            return totals;
        }
    }
}
