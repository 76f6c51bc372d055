// Materials of a building's levels that use the compressed texture files (TextureFiles) instead of
// the uncompressed RGBA32 textures glTFast embeds in the imported .glb: a copy of each of
// glTFast's materials (same shader and properties) with every texture property that holds an
// embedded texture pointed at the imported file of the same image. Saved as
// <tile>/Prefabs/Materials/<building>/lod<k>_<n>.mat (rewritten in place on rebuilds, so their
// GUIDs and the prefabs' references stay). glTFast's embedded textures stay in its imported
// asset but no prefab references them, so they are not in player builds.
using System.Collections.Generic;
using UnityEditor;
using UnityEngine;

namespace VWorldLod.EditorTools
{
    public static class LevelMaterials
    {
        /// <summary>
        /// Per level, glTFast's material -> the package's material with the compressed textures, for the
        /// renderers of levelAssets (textures: per level, glTFast texture name -> texture file).
        /// A material without an embedded texture (or whose file did not import) maps to itself.
        /// </summary>
        public static Dictionary<Material, Material>[] Make(BuildingPlan building, GameObject[] levelAssets,
                                                           Dictionary<string, string>[] textures, string materialFolder)
        {
            var result = new Dictionary<Material, Material>[levelAssets.Length];
            for (int k = 0; k < levelAssets.Length; k++)
            {
                result[k] = new Dictionary<Material, Material>();
                int n = 0;
                foreach (Renderer renderer in levelAssets[k].GetComponentsInChildren<Renderer>(true))
                    foreach (Material source in renderer.sharedMaterials)
                    {
                        if (source == null || result[k].ContainsKey(source)) continue;
                        result[k][source] = WithFileTextures(source, textures[k], materialFolder + "/lod" + k + "_" + n + ".mat");
                        n++;
                    }
            }
            return result;
        }

        /// <summary>Points the renderers' materials at the package's ones (map from Make).</summary>
        public static void Apply(Renderer[] renderers, Dictionary<Material, Material> map)
        {
            foreach (Renderer renderer in renderers)
            {
                Material[] materials = renderer.sharedMaterials;
                bool changed = false;
                for (int i = 0; i < materials.Length; i++)
                {
                    Material replacement;
                    if (materials[i] != null && map.TryGetValue(materials[i], out replacement) && replacement != materials[i])
                    {
                        materials[i] = replacement;
                        changed = true;
                    }
                }
                if (changed) renderer.sharedMaterials = materials;
            }
        }

        static Material WithFileTextures(Material source, Dictionary<string, string> files, string path)
        {
            var swaps = new List<KeyValuePair<string, Texture>>();
            foreach (string property in source.GetTexturePropertyNames())
            {
                Texture embedded = source.GetTexture(property);
                string file;
                if (embedded == null || !files.TryGetValue(embedded.name, out file)) continue;
                var imported = AssetDatabase.LoadAssetAtPath<Texture2D>(file);
                if (imported == null)
                {
                    Debug.LogWarning("VWorld LoD: " + file + " did not import as a texture; " + source.name + " keeps glTFast's uncompressed texture");
                    continue;
                }
                swaps.Add(new KeyValuePair<string, Texture>(property, imported));
            }
            if (swaps.Count == 0) return source;
            Material target = AssetDatabase.LoadAssetAtPath<Material>(path);
            bool created = target == null;
            if (created) target = new Material(source);
            else EditorUtility.CopySerialized(source, target);
            target.name = System.IO.Path.GetFileNameWithoutExtension(path);
            foreach (KeyValuePair<string, Texture> swap in swaps) target.SetTexture(swap.Key, swap.Value);
            if (created) AssetDatabase.CreateAsset(target, path);
            else EditorUtility.SetDirty(target);
            return target;
        }
    }
}
