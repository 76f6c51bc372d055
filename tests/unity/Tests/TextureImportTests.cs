// The Editor import's compressed textures and up-to-date check: image headers, the import rules
// and their GPU bytes, what the postprocessor sets on a TextureImporter, which files it touches,
// the build stamp, the progress display per trigger; and, on files made by the Python side, the
// images read out of exported .glb files and the GPU bytes of a whole tile.
using System;
using System.Collections.Generic;
using System.IO;
using System.Reflection;
using System.Text;
using UnityEditor;
using UnityEngine;
using VWorldLod.EditorTools;

namespace VWorldLod.Tests
{
    public static class TextureImportTests
    {
        // A JPEG's first bytes up to its frame header: SOI, an APP0 segment, then SOFn with the size.
        static byte[] JpegHeader(int width, int height, byte sof)
        {
            var b = new List<byte> { 0xFF, 0xD8, 0xFF, 0xE0, 0x00, 0x06, 0x4A, 0x46, 0x49, 0x46 };
            b.AddRange(new byte[] { 0xFF, sof, 0x00, 0x11, 0x08, (byte)(height >> 8), (byte)height, (byte)(width >> 8), (byte)width, 0x03 });
            b.AddRange(new byte[20]);
            return b.ToArray();
        }

        static byte[] Chunk(string type, byte[] data)
        {
            var b = new List<byte> { (byte)(data.Length >> 24), (byte)(data.Length >> 16), (byte)(data.Length >> 8), (byte)data.Length };
            b.AddRange(Encoding.ASCII.GetBytes(type));
            b.AddRange(data);
            b.AddRange(new byte[4]); // CRC (not checked)
            return b.ToArray();
        }

        static byte[] PngHeader(int width, int height, byte colourType, bool trns)
        {
            var b = new List<byte> { 0x89, (byte)'P', (byte)'N', (byte)'G', 0x0D, 0x0A, 0x1A, 0x0A };
            b.AddRange(Chunk("IHDR", new byte[] { (byte)(width >> 24), (byte)(width >> 16), (byte)(width >> 8), (byte)width,
                                                 (byte)(height >> 24), (byte)(height >> 16), (byte)(height >> 8), (byte)height, 8, colourType, 0, 0, 0 }));
            if (trns) b.AddRange(Chunk("tRNS", new byte[] { 0, 0 }));
            b.AddRange(Chunk("IDAT", new byte[3]));
            return b.ToArray();
        }

        static string TempFolder()
        {
            string path = Path.Combine(Path.GetTempPath(), "vworldlod-tex-" + Guid.NewGuid().ToString("N"));
            Directory.CreateDirectory(path);
            return path.Replace('\\', '/');
        }

        static void Preprocess(TextureImportPostprocessor post)
        {
            typeof(TextureImportPostprocessor).GetMethod("OnPreprocessTexture", BindingFlags.Instance | BindingFlags.NonPublic).Invoke(post, null);
        }

        static TilePlan TwoLevelPlan(string folder)
        {
            File.WriteAllText(folder + "/lod_manifest.json", "{\"format\": \"vworld-lod-manifest\"}");
            Directory.CreateDirectory(folder + "/B1");
            File.WriteAllBytes(folder + "/B1/lod0.glb", new byte[] { 1, 2, 3 });
            File.WriteAllBytes(folder + "/B1/lod1.glb", new byte[] { 4, 5 });
            return new TilePlan
            {
                ManifestPath = folder + "/lod_manifest.json",
                Folder = folder,
                TileName = "15_1_2",
                Buildings = new[]
                {
                    new BuildingPlan
                    {
                        Id = "B1",
                        Name = "B1",
                        Levels = new[] { new LevelPlan { Level = 0, Path = folder + "/B1/lod0.glb" }, new LevelPlan { Level = 1, Path = folder + "/B1/lod1.glb" } },
                    },
                },
                Failures = new ManifestException[0],
            };
        }

        public static void RunSelfContained(TestRunner t)
        {
            t.Check("image header: JPEG size from its SOF0 / SOF2 frame header, no alpha", () =>
            {
                ImageInfo a = ImageHeader.Read(JpegHeader(512, 256, 0xC0));
                Assert.Equal(512, a.Width, "width");
                Assert.Equal(256, a.Height, "height");
                Assert.True(!a.HasAlpha, "JPEG has no alpha");
                Assert.Equal(1000, ImageHeader.Read(JpegHeader(1000, 20, 0xC2)).Width, "progressive JPEG width");
                Assert.Throws<InvalidDataException>(() => ImageHeader.Read(new byte[] { 0xFF, 0xD8, 0xFF, 0xD9 }), "JPEG without a frame header");
            });

            t.Check("image header: PNG size; alpha from colour type 6 / 4 or a tRNS chunk", () =>
            {
                ImageInfo rgba = ImageHeader.Read(PngHeader(300, 200, 6, false));
                Assert.Equal(300, rgba.Width, "width");
                Assert.Equal(200, rgba.Height, "height");
                Assert.True(rgba.HasAlpha, "RGBA PNG has alpha");
                Assert.True(ImageHeader.Read(PngHeader(8, 8, 4, false)).HasAlpha, "grey + alpha");
                Assert.True(!ImageHeader.Read(PngHeader(8, 8, 2, false)).HasAlpha, "RGB PNG is opaque");
                Assert.True(ImageHeader.Read(PngHeader(8, 8, 2, true)).HasAlpha, "RGB PNG with tRNS");
                Assert.Throws<InvalidDataException>(() => ImageHeader.Read(new byte[] { 1, 2, 3, 4 }), "not an image");
            });

            t.Check("texture rules: GPU bytes with the mip chain, by blocks (Unity's documented sizes)", () =>
            {
                // 512^2: RGBA32 4 bytes/pixel over 512^2 .. 1^2 = 4 * 349525.
                Assert.Equal(1398100L, TextureImportRules.GpuBytes(512, 512, GpuFormat.RGBA32, true), "RGBA32 512^2 with mips");
                Assert.Equal(1048576L, TextureImportRules.GpuBytes(512, 512, GpuFormat.RGBA32, false), "RGBA32 512^2 without mips");
                // DXT1: 8 bytes per 4x4 block; 4x4, 2x2 and 1x1 mips take one block each.
                Assert.Equal(131072L + 32768 + 8192 + 2048 + 512 + 128 + 32 + 8 + 8 + 8, TextureImportRules.GpuBytes(512, 512, GpuFormat.DXT1, true), "DXT1 512^2");
                Assert.Equal(2L * TextureImportRules.GpuBytes(512, 512, GpuFormat.DXT1, true), TextureImportRules.GpuBytes(512, 512, GpuFormat.BC7, true), "BC7 is twice DXT1");
                // ASTC 6x6: 16 bytes per 6x6 block, partial blocks count whole: 86^2 blocks at 512.
                Assert.Equal(86L * 86 * 16, TextureImportRules.GpuBytes(512, 512, GpuFormat.ASTC_6x6, false), "ASTC 6x6 512^2");
                Assert.Equal(16L, TextureImportRules.GpuBytes(1, 1, GpuFormat.ASTC_6x6, true), "1x1 is one block");
                // Non-square, non-power-of-two (the exporter's multiples of 4): 20x8 -> 10x4 -> 5x2 -> 2x1 -> 1x1.
                Assert.Equal(4L * (20 * 8 + 10 * 4 + 5 * 2 + 2 * 1 + 1), TextureImportRules.GpuBytes(20, 8, GpuFormat.RGBA32, true), "20x8 chain");
            });

            t.Check("texture rules: per platform DXT1/BC7, ASTC 6x6, WebGL S3TC; sRGB, mips, streaming, max size keeps the size", () =>
            {
                TextureImportPlan opaque = TextureImportRules.PlanFor(new ImageInfo { Width = 600, Height = 300 });
                var formats = new Dictionary<string, GpuFormat>();
                foreach (PlatformFormat p in opaque.Platforms) formats[p.Platform] = p.Format;
                Assert.Equal(GpuFormat.DXT1, formats["Standalone"], "desktop opaque");
                Assert.Equal(GpuFormat.ASTC_6x6, formats["Android"], "Android");
                Assert.Equal(GpuFormat.ASTC_6x6, formats["iPhone"], "iOS");
                Assert.Equal(GpuFormat.DXT1, formats["WebGL"], "WebGL opaque");
                Assert.True(opaque.SRgb && opaque.Mipmaps && opaque.StreamingMipmaps && !opaque.AlphaFromInput, "sRGB, mipmaps, streaming, no alpha");
                Assert.Equal(1024, opaque.MaxSize, "600 px fits under 1024");
                TextureImportPlan alpha = TextureImportRules.PlanFor(new ImageInfo { Width = 4096, Height = 64, HasAlpha = true });
                Assert.Equal(GpuFormat.BC7, alpha.Platforms[0].Format, "desktop alpha");
                Assert.Equal(GpuFormat.DXT5, alpha.Platforms[3].Format, "WebGL alpha");
                Assert.True(alpha.AlphaFromInput, "alpha from the image");
                Assert.Equal(4096, alpha.MaxSize, "a 4096 atlas is not shrunk to Unity's default 2048");
                Assert.Equal(32, TextureImportRules.MaxSizeFor(16), "Unity's smallest max size");
                Assert.Equal(512, TextureImportRules.MaxSizeFor(512), "exact power of two");
                Assert.Equal(16384, TextureImportRules.MaxSizeFor(40000), "Unity's largest max size");
            });

            t.Check("postprocessor: a building texture gets the rules on a TextureImporter (Unity's enum values)", () =>
            {
                string tile = TempFolder();
                File.WriteAllText(tile + "/lod_manifest.json", "{}");
                Directory.CreateDirectory(tile + "/Textures/B1");
                File.WriteAllBytes(tile + "/Textures/B1/lod1_0.png", PngHeader(256, 128, 6, false));
                var importer = new TextureImporter();
                var post = new TextureImportPostprocessor { assetPath = tile + "/Textures/B1/lod1_0.png" };
                post.importer = importer;
                Preprocess(post);
                Assert.True(importer.sRGBTexture && importer.mipmapEnabled && importer.streamingMipmaps, "sRGB, mipmaps, mipmap streaming");
                Assert.True(!importer.isReadable, "no CPU copy");
                Assert.Equal(TextureImporterNPOTScale.None, importer.npotScale, "no power-of-two rescale");
                Assert.Equal(TextureImporterAlphaSource.FromInput, importer.alphaSource, "alpha from the PNG");
                Assert.Equal(FilterMode.Trilinear, importer.filterMode, "trilinear (the glTF sampler's LINEAR_MIPMAP_LINEAR)");
                Assert.Equal(256, importer.maxTextureSize, "max size keeps 256");
                Assert.Equal(4, importer.platforms.Count, "four platform overrides");
                var byName = new Dictionary<string, TextureImporterPlatformSettings>();
                foreach (TextureImporterPlatformSettings s in importer.platforms) byName[s.name] = s;
                Assert.Equal(25, (int)byName["Standalone"].format, "Standalone: BC7 (25)");
                Assert.Equal(50, (int)byName["Android"].format, "Android: ASTC_6x6 (50)");
                Assert.Equal(50, (int)byName["iPhone"].format, "iPhone: ASTC_6x6 (50)");
                Assert.Equal(12, (int)byName["WebGL"].format, "WebGL: DXT5 (12)");
                Assert.True(byName["Android"].overridden && byName["Android"].maxTextureSize == 256, "overridden, max size");
                Assert.Equal(10, (int)TextureImportPostprocessor.UnityFormat(GpuFormat.DXT1), "DXT1 is 10");
                Assert.Equal("vworldlod-texture 256x128 alpha", importer.userData, "what the settings were made for");
            });

            t.Check("postprocessor: keeps settings made for this image (Inspector edits), redoes them for a new size, leaves other textures alone", () =>
            {
                string tile = TempFolder();
                File.WriteAllText(tile + "/lod_manifest.json", "{}");
                Directory.CreateDirectory(tile + "/Textures/B1");
                File.WriteAllBytes(tile + "/Textures/B1/lod0_0.jpg", JpegHeader(64, 64, 0xC0));
                File.WriteAllBytes(tile + "/B1.jpg", JpegHeader(64, 64, 0xC0));
                var existing = new TextureImporter { missing = false, userData = "vworldlod-texture 64x64", maxTextureSize = 2048 };
                var post = new TextureImportPostprocessor { assetPath = tile + "/Textures/B1/lod0_0.jpg" };
                post.importer = existing;
                Preprocess(post);
                Assert.Equal(0, existing.platforms.Count, "settings made for this image are kept");
                Assert.Equal(2048, existing.maxTextureSize, "an Inspector edit stays");
                File.WriteAllBytes(tile + "/Textures/B1/lod0_0.jpg", JpegHeader(1024, 512, 0xC0));
                Preprocess(post);
                Assert.Equal(4, existing.platforms.Count, "a new export's bigger image gets the rules again");
                Assert.Equal(1024, existing.maxTextureSize, "max size follows the new image");
                Assert.Equal("vworldlod-texture 1024x512", existing.userData, "recorded");
                var other = new TextureImporter();
                post = new TextureImportPostprocessor { assetPath = tile + "/B1.jpg" };
                post.importer = other;
                Preprocess(post);
                Assert.Equal(0, other.platforms.Count, "a texture that is not a building level's");
            });

            t.Check("texture files: where a level's images go and which paths the postprocessor claims", () =>
            {
                var image = new GlbImage { Index = 2, MimeType = "image/png" };
                Assert.Equal("Assets/T/Textures/B 1/lod1_2.png", TextureFiles.PathFor("Assets/T", "B 1", 1, image), "path");
                Func<string, bool> manifestAt = p => p == "Assets/T/lod_manifest.json";
                Assert.True(TextureFiles.IsBuildingTexture("Assets/T/Textures/B 1/lod1_2.png", manifestAt), "a level texture");
                Assert.True(!TextureFiles.IsBuildingTexture("Assets/U/Textures/B1/lod1_2.png", manifestAt), "no manifest beside it");
                Assert.True(!TextureFiles.IsBuildingTexture("Assets/T/Textures/B1/photo.png", manifestAt), "another name");
                Assert.True(!TextureFiles.IsBuildingTexture("Assets/T/Textures/B1/lod1_2.tga", manifestAt), "another type");
                Assert.True(!TextureFiles.IsBuildingTexture("Assets/T/Other/B1/lod1_2.png", manifestAt), "another folder");
            });

            t.Check("texture files: an unchanged image is not rewritten (no re-import, no re-compression)", () =>
            {
                string path = TempFolder() + "/sub/lod0_0.jpg";
                Assert.True(TextureFiles.WriteIfChanged(path, new byte[] { 1, 2, 3 }), "new file written");
                Assert.True(!TextureFiles.WriteIfChanged(path, new byte[] { 1, 2, 3 }), "same bytes: not written");
                Assert.True(TextureFiles.WriteIfChanged(path, new byte[] { 1, 2, 4 }), "changed bytes written");
                Assert.Equal(4, File.ReadAllBytes(path)[2], "new content");
                Assert.True(!File.Exists(path + ".tmp~"), "no temporary file left");
            });

            t.Check("build stamp: up to date only for the same manifest and level files with every prefab present", () =>
            {
                string tile = TempFolder();
                TilePlan plan = TwoLevelPlan(tile);
                string prefabs = tile + "/Prefabs";
                Directory.CreateDirectory(prefabs);
                Assert.True(!BuildStamp.IsUpToDate(plan, prefabs, File.Exists), "nothing built yet");
                File.WriteAllText(prefabs + "/15_1_2.prefab", "");
                File.WriteAllText(prefabs + "/B1.prefab", "");
                string hash = BuildStamp.Hash(plan);
                Assert.Equal(64, hash.Length, "SHA-256 hex");
                Assert.Equal(hash, BuildStamp.Hash(plan), "the same files hash alike");
                BuildStamp.Record(prefabs, hash);
                Assert.True(BuildStamp.IsUpToDate(plan, prefabs, File.Exists), "recorded: up to date");
                File.WriteAllBytes(tile + "/B1/lod1.glb", new byte[] { 4, 6 });
                Assert.True(!BuildStamp.IsUpToDate(plan, prefabs, File.Exists), "a level file changed");
                File.WriteAllBytes(tile + "/B1/lod1.glb", new byte[] { 4, 5 });
                Assert.True(BuildStamp.IsUpToDate(plan, prefabs, File.Exists), "changed back");
                File.AppendAllText(plan.ManifestPath, " ");
                Assert.True(!BuildStamp.IsUpToDate(plan, prefabs, File.Exists), "the manifest changed");
                BuildStamp.Record(prefabs, BuildStamp.Hash(plan));
                File.Delete(prefabs + "/B1.prefab");
                Assert.True(!BuildStamp.IsUpToDate(plan, prefabs, File.Exists), "a building prefab is missing");
                File.WriteAllText(prefabs + "/B1.prefab", "");
                BuildStamp.Clear(prefabs);
                Assert.True(!BuildStamp.IsUpToDate(plan, prefabs, File.Exists), "cleared (a failed build)");
                Assert.True(BuildStamp.FileName.StartsWith("."), "a dot-file: Unity does not import it");
            });

            t.Check("build progress: the menu shows the modal bar; automatic builds report in the background and skip when up to date", () =>
            {
                Assert.True(BuildProgress.For(BuildTrigger.Menu, "m") is BuildProgress.ModalProgress, "menu: modal");
                IBuildProgress background = BuildProgress.For(BuildTrigger.Automatic, "Assets/T/lod_manifest.json");
                Assert.True(background is BuildProgress.BackgroundProgress, "automatic: background");
                Progress.calls.Clear();
                Assert.True(!background.Step("B1", 0f), "never cancelled");
                background.Step("B2", 0.5f);
                background.Done(true);
                Assert.Equal("Start VWorld LoD|Report 0 B1|Report 0.5 B2|Finish Succeeded", string.Join("|", Progress.calls.ToArray()), "Progress API calls");
                Assert.True(BuildProgress.SkipsWhenUpToDate(BuildTrigger.Automatic), "automatic builds skip up-to-date prefabs");
                Assert.True(!BuildProgress.SkipsWhenUpToDate(BuildTrigger.Menu), "the menu always rebuilds");
            });
        }

        /// <summary>--glb-images SPEC: {"cases": [{"glb", "images": [{"index", "name", "mime", "length", "sha256", "width", "height", "alpha"}]}]} from the Python side.</summary>
        public static void RunGlbImages(TestRunner t, string specPath)
        {
            var spec = (Dictionary<string, object>)PlainJson.Parse(File.ReadAllText(specPath));
            foreach (object item in (List<object>)spec["cases"])
            {
                var c = (Dictionary<string, object>)item;
                string glb = (string)c["glb"];
                t.Check("glb images: " + Path.GetFileName(Path.GetDirectoryName(glb)) + "/" + Path.GetFileName(glb) + " as the Python side reads it", () =>
                {
                    List<GlbImage> images = GlbImages.Read(glb);
                    var expected = (List<object>)c["images"];
                    Assert.Equal(expected.Count, images.Count, "image count");
                    for (int i = 0; i < images.Count; i++)
                    {
                        var e = (Dictionary<string, object>)expected[i];
                        Assert.Equal((int)(double)e["index"], images[i].Index, "index");
                        Assert.Equal((string)e["name"], images[i].TextureName, "glTFast's texture name");
                        Assert.Equal((string)e["mime"], images[i].MimeType, "mime");
                        Assert.Equal((string)e["sha256"], Sha256(images[i].Data), "bytes (SHA-256) of image " + i);
                        ImageInfo info = ImageHeader.Read(images[i].Data);
                        Assert.Equal((int)(double)e["width"], info.Width, "width");
                        Assert.Equal((int)(double)e["height"], info.Height, "height");
                        Assert.Equal((bool)e["alpha"], info.HasAlpha, "alpha");
                    }
                });
            }
            t.Check("glb images: a truncated file is refused naming it", () =>
            {
                string broken = TempFolder() + "/broken.glb";
                byte[] whole = File.ReadAllBytes((string)((Dictionary<string, object>)((List<object>)spec["cases"])[0])["glb"]);
                File.WriteAllBytes(broken, new ArraySegment<byte>(whole, 0, 40).ToArray());
                Assert.Contains("broken.glb: ", Assert.Throws<InvalidDataException>(() => GlbImages.Read(broken), "truncated").Message, "names the file");
            });
        }

        /// <summary>--extract MANIFEST: every building's level images written under a copy's Textures/, byte for byte.</summary>
        public static void RunExtract(TestRunner t, string manifestPath)
        {
            t.Check("texture files: every level's images written out byte for byte, then left alone", () =>
            {
                TilePlan plan = LodPlanner.Load(manifestPath, new PlainJsonManifestParser(), File.Exists);
                string folder = TempFolder();
                var written = new List<string>();
                foreach (BuildingPlan building in plan.Buildings)
                {
                    Dictionary<string, string>[] map = TextureFiles.Extract(building, folder, written);
                    for (int k = 0; k < building.Levels.Length; k++)
                        foreach (GlbImage image in GlbImages.Read(building.Levels[k].Path))
                        {
                            string path = TextureFiles.PathFor(folder, building.Name, k, image);
                            Assert.Equal(path, map[k][image.TextureName], "glTFast texture name -> file");
                            Assert.Equal(Sha256(image.Data), Sha256(File.ReadAllBytes(path)), path);
                        }
                }
                Assert.True(written.Count > 0, "files written");
                var again = new List<string>();
                foreach (BuildingPlan building in plan.Buildings) TextureFiles.Extract(building, folder, again);
                Assert.Equal(0, again.Count, "a second extraction rewrites nothing");
            });
        }

        /// <summary>--texture-bytes MANIFEST: GPU bytes of every level's images, today's and per platform (MEASURE lines).</summary>
        public static void RunTextureBytes(TestRunner t, string manifestPath)
        {
            t.Check("texture bytes: " + manifestPath, () =>
            {
                TilePlan plan = LodPlanner.Load(manifestPath, new PlainJsonManifestParser(), File.Exists);
                var infos = new List<ImageInfo>();
                foreach (BuildingPlan building in plan.Buildings)
                    foreach (LevelPlan level in building.Levels)
                        foreach (GlbImage image in GlbImages.Read(level.Path))
                            infos.Add(ImageHeader.Read(image.Data));
                Assert.True(infos.Count > 0, "the tile has textures");
                foreach (KeyValuePair<string, long> total in TextureImportRules.Totals(infos))
                    Console.WriteLine("MEASURE gpu_texture_bytes." + total.Key.Replace(' ', '_') + " " + total.Value);
                Console.WriteLine("MEASURE gpu_texture_images " + infos.Count);
            });
        }

        static string Sha256(byte[] data)
        {
            using (var sha = System.Security.Cryptography.SHA256.Create())
            {
                var hex = new StringBuilder();
                foreach (byte b in sha.ComputeHash(data)) hex.Append(b.ToString("x2"));
                return hex.ToString();
            }
        }
    }
}
