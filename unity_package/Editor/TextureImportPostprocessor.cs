// Gives the building textures the Editor import writes out (TextureFiles) the package's import
// settings (TextureImportRules): per-platform compression, sRGB, mipmaps, mipmap streaming, a max
// size that keeps the exported size. Applied when Unity has no settings for the file yet (its
// first import, or after its .meta was deleted) or when the image is no longer the one they were
// made for (another size or alpha after a new export: the max size must follow), which the
// importer's userData records; otherwise changes made in the Inspector stay.
using System.IO;
using UnityEditor;
using UnityEngine;

namespace VWorldLod.EditorTools
{
    public class TextureImportPostprocessor : AssetPostprocessor
    {
        void OnPreprocessTexture()
        {
            var importer = assetImporter as TextureImporter;
            if (importer == null || !TextureFiles.IsBuildingTexture(assetPath, File.Exists)) return;
            ImageInfo image;
            try
            {
                image = ImageHeader.Read(File.ReadAllBytes(assetPath));
            }
            catch (InvalidDataException e)
            {
                Debug.LogWarning("VWorld LoD: " + assetPath + ": " + e.Message + "; Unity's default texture settings used");
                return;
            }
            string made = TextureImportRules.MadeFor(image);
            if (!importer.importSettingsMissing && importer.userData == made) return; // kept: maybe edited in the Inspector
            Apply(importer, TextureImportRules.PlanFor(image));
            importer.userData = made;
        }

        /// <summary>Sets every setting of plan on importer (default and per-platform).</summary>
        public static void Apply(TextureImporter importer, TextureImportPlan plan)
        {
            importer.textureType = TextureImporterType.Default;
            importer.sRGBTexture = plan.SRgb;
            importer.alphaSource = plan.AlphaFromInput ? TextureImporterAlphaSource.FromInput : TextureImporterAlphaSource.None;
            importer.mipmapEnabled = plan.Mipmaps;
            importer.streamingMipmaps = plan.StreamingMipmaps;
            importer.npotScale = TextureImporterNPOTScale.None;
            importer.isReadable = false;
            importer.wrapMode = TextureWrapMode.Repeat;
            importer.filterMode = FilterMode.Trilinear;
            importer.maxTextureSize = plan.MaxSize;
            importer.textureCompression = TextureImporterCompression.Compressed;
            foreach (PlatformFormat p in plan.Platforms)
            {
                importer.SetPlatformTextureSettings(new TextureImporterPlatformSettings
                {
                    name = p.Platform,
                    overridden = true,
                    maxTextureSize = plan.MaxSize,
                    format = UnityFormat(p.Format),
                    textureCompression = TextureImporterCompression.Compressed,
                });
            }
        }

        /// <summary>Unity's TextureImporterFormat for a rule's format.</summary>
        public static TextureImporterFormat UnityFormat(GpuFormat format)
        {
            switch (format)
            {
                case GpuFormat.DXT1: return TextureImporterFormat.DXT1;
                case GpuFormat.DXT5: return TextureImporterFormat.DXT5;
                case GpuFormat.BC7: return TextureImporterFormat.BC7;
                case GpuFormat.ASTC_6x6: return TextureImporterFormat.ASTC_6x6;
                default: return TextureImporterFormat.RGBA32;
            }
        }
    }
}
