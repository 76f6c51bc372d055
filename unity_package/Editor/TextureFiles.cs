// Where the Editor import writes a level's embedded images, and how the texture postprocessor
// recognises them: <tile folder>/Textures/<building>/lod<k>_<image index>.jpg|.png, beside the
// tile's lod_manifest.json. Plain C# (paths as Unity's "Assets/..." with '/').
//
// The files are byte-for-byte the images the .glb embeds (LOD0's are the source atlas's bytes):
// only Unity's TextureImporter, which compresses them per platform, sees them differently.
using System;
using System.Collections;
using System.Collections.Generic;
using System.IO;

namespace VWorldLod.EditorTools
{
    public static class TextureFiles
    {
        public const string FolderName = "Textures";

        /// <summary>The asset path of image (from the level's .glb) of building's level k in tileFolder.</summary>
        public static string PathFor(string tileFolder, string buildingName, int level, GlbImage image)
        {
            return tileFolder + "/" + FolderName + "/" + buildingName + "/lod" + level + "_" + image.Index + image.Extension;
        }

        /// <summary>
        /// Whether assetPath is a texture the Editor import wrote: ".../Textures/&lt;building&gt;/lod&lt;k&gt;_&lt;i&gt;.jpg|.png"
        /// with the tile's lod_manifest.json two folders up (fileExists decides, for tests).
        /// </summary>
        public static bool IsBuildingTexture(string assetPath, Func<string, bool> fileExists)
        {
            string path = assetPath.Replace('\\', '/');
            string ext = Path.GetExtension(path).ToLowerInvariant();
            if (ext != ".jpg" && ext != ".png") return false;
            string[] parts = path.Split('/');
            if (parts.Length < 4 || parts[parts.Length - 3] != FolderName) return false;
            string file = Path.GetFileNameWithoutExtension(parts[parts.Length - 1]);
            int underscore = file.IndexOf('_');
            int level, index;
            if (!file.StartsWith("lod") || underscore < 4
                || !int.TryParse(file.Substring(3, underscore - 3), out level)
                || !int.TryParse(file.Substring(underscore + 1), out index)) return false;
            string tileFolder = string.Join("/", parts, 0, parts.Length - 3);
            return fileExists(tileFolder + "/" + VWorldLodMenu.ManifestFileName);
        }

        /// <summary>
        /// Writes every embedded image of building's levels under tileFolder (a file is rewritten only
        /// when its bytes differ, so an unchanged re-import does not re-compress it). Returns per level
        /// glTFast's texture name -> the file's asset path; the paths written are added to written.
        /// </summary>
        public static Dictionary<string, string>[] Extract(BuildingPlan building, string tileFolder, List<string> written)
        {
            var result = new Dictionary<string, string>[building.Levels.Length];
            for (int k = 0; k < building.Levels.Length; k++)
            {
                result[k] = new Dictionary<string, string>();
                var duplicates = new HashSet<string>();
                foreach (GlbImage image in GlbImages.Read(building.Levels[k].Path))
                {
                    string path = PathFor(tileFolder, building.Name, k, image);
                    if (WriteIfChanged(path, image.Data)) written.Add(path);
                    // Two images of one level with the same name: glTFast's textures cannot be told apart by name; keep glTFast's.
                    if (result[k].ContainsKey(image.TextureName)) duplicates.Add(image.TextureName);
                    else result[k][image.TextureName] = path;
                }
                foreach (string name in duplicates) result[k].Remove(name);
            }
            return result;
        }

        /// <summary>Writes data to path unless the file already holds exactly these bytes; true when written.</summary>
        public static bool WriteIfChanged(string path, byte[] data)
        {
            if (File.Exists(path))
            {
                byte[] old = File.ReadAllBytes(path);
                if (old.Length == data.Length && ((IStructuralEquatable)old).Equals(data, StructuralComparisons.StructuralEqualityComparer)) return false;
            }
            Directory.CreateDirectory(Path.GetDirectoryName(path));
            string temporary = path + ".tmp~";
            File.WriteAllBytes(temporary, data);
            if (File.Exists(path)) File.Delete(path);
            File.Move(temporary, path);
            return true;
        }
    }
}
