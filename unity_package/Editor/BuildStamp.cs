// The up-to-date check of the Editor import: a SHA-256 over what the prefabs are built from (the
// builder's version, the manifest's bytes, every level file's bytes in plan order) is recorded in
// <tile>/Prefabs/.vworldlod-build after a complete build. An automatic build (a manifest imported:
// a copy, a Library rebuild, a fresh clone) is skipped when the recorded hash matches and the tile
// prefab and every building prefab exist; the menu item always rebuilds. The file starts with a
// dot, so Unity does not import it (it is not an asset), and it travels with the prefabs in
// version control. Plain C#.
using System;
using System.IO;
using System.Security.Cryptography;
using System.Text;

namespace VWorldLod.EditorTools
{
    public static class BuildStamp
    {
        /// <summary>Changes whenever the builder makes different prefabs from the same files (forces a rebuild).</summary>
        public const string BuilderVersion = "vworldlod-prefabs-2";
        public const string FileName = ".vworldlod-build";

        /// <summary>Lower-case hex SHA-256 of the builder version, the manifest's bytes and each level file's bytes.</summary>
        public static string Hash(TilePlan plan)
        {
            using (var sha = SHA256.Create())
            {
                Add(sha, Encoding.UTF8.GetBytes(BuilderVersion));
                Add(sha, File.ReadAllBytes(plan.ManifestPath));
                foreach (BuildingPlan building in plan.Buildings)
                    foreach (LevelPlan level in building.Levels)
                    {
                        Add(sha, Encoding.UTF8.GetBytes(level.Path));
                        Add(sha, File.ReadAllBytes(level.Path));
                    }
                sha.TransformFinalBlock(new byte[0], 0, 0);
                var hex = new StringBuilder(64);
                foreach (byte b in sha.Hash) hex.Append(b.ToString("x2"));
                return hex.ToString();
            }
        }

        // Length-prefixed, so moving bytes from one piece to the next changes the hash.
        static void Add(HashAlgorithm sha, byte[] data)
        {
            byte[] length = BitConverter.GetBytes((long)data.Length);
            sha.TransformBlock(length, 0, length.Length, null, 0);
            sha.TransformBlock(data, 0, data.Length, null, 0);
        }

        public static string StampPath(string prefabFolder)
        {
            return prefabFolder + "/" + FileName;
        }

        /// <summary>Whether the prefabs in prefabFolder were built from exactly these files (and all exist).</summary>
        public static bool IsUpToDate(TilePlan plan, string prefabFolder, Func<string, bool> fileExists)
        {
            return IsUpToDate(plan, prefabFolder, fileExists, Hash(plan));
        }

        /// <summary>IsUpToDate with the files' hash already computed (Hash(plan)).</summary>
        public static bool IsUpToDate(TilePlan plan, string prefabFolder, Func<string, bool> fileExists, string hash)
        {
            string stamp = StampPath(prefabFolder);
            if (!fileExists(stamp) || !fileExists(prefabFolder + "/" + plan.TileName + ".prefab")) return false;
            foreach (BuildingPlan building in plan.Buildings)
                if (!fileExists(prefabFolder + "/" + building.Name + ".prefab")) return false;
            return File.ReadAllText(stamp).Trim() == hash;
        }

        /// <summary>Records hash as the state the prefabs in prefabFolder were built from.</summary>
        public static void Record(string prefabFolder, string hash)
        {
            File.WriteAllText(StampPath(prefabFolder), hash + "\n");
        }

        /// <summary>Forgets the recorded state (a build that failed or was cancelled must run again).</summary>
        public static void Clear(string prefabFolder)
        {
            if (File.Exists(StampPath(prefabFolder))) File.Delete(StampPath(prefabFolder));
        }
    }
}
