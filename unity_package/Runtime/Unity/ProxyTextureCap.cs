// Leaves the finest mipmapLimit mip levels out of a loaded proxy's textures (ProxyStreamer asks
// for it by how large the proxy's texel looks at its distance): glTFast has no such import setting (its ImportSettings hold mipmap
// generation, filters and anisotropy only), so after the load each Texture2D with a mip chain
// is replaced by a smaller one holding its mip levels from mipmapLimit on (one at least), copied on
// the GPU (Graphics.CopyTexture, same GraphicsFormat: no decode, no CPU copy, sRGB kept), and the
// original is destroyed: the full atlas stays resident only during the load. Where the GPU cannot
// copy textures (SystemInfo.copyTextureSupport None) or a texture has no mip chain, it stays whole.
using System.Collections.Generic;
using UnityEngine;
using UnityEngine.Experimental.Rendering;

namespace VWorldLod
{
    public static class ProxyTextureCap
    {
        /// <summary>
        /// Replaces, in the renderers' materials, every Texture2D with a mip chain by its mip
        /// levels from mipmapLimit on (0: none left out; its coarsest level is always kept);
        /// returns the textures made (the caller destroys them with the proxy).
        /// </summary>
        public static List<Texture2D> Apply(Renderer[] renderers, int mipmapLimit)
        {
            var made = new List<Texture2D>();
            if (mipmapLimit <= 0 || SystemInfo.copyTextureSupport == CopyTextureSupport.None) return made;
            var replaced = new Dictionary<Texture, Texture2D>();
            foreach (Renderer renderer in renderers)
                foreach (Material material in renderer.sharedMaterials)
                {
                    if (material == null) continue;
                    foreach (string property in material.GetTexturePropertyNames())
                    {
                        var texture = material.GetTexture(property) as Texture2D;
                        if (texture == null) continue;
                        Texture2D small;
                        if (!replaced.TryGetValue(texture, out small))
                        {
                            small = Smaller(texture, mipmapLimit);
                            replaced[texture] = small;
                            if (small != null) made.Add(small);
                        }
                        if (small != null) material.SetTexture(property, small);
                    }
                }
            foreach (KeyValuePair<Texture, Texture2D> pair in replaced)
                if (pair.Value != null) Object.Destroy(pair.Key);
            return made;
        }

        // texture's mip levels from mipmapLimit on (its coarsest kept), or null (no mip chain).
        static Texture2D Smaller(Texture2D texture, int mipmapLimit)
        {
            int skip = 0, width = texture.width, height = texture.height;
            while (skip < texture.mipmapCount - 1 && skip < mipmapLimit)
            {
                skip++;
                width = System.Math.Max(1, width / 2);
                height = System.Math.Max(1, height / 2);
            }
            if (skip == 0) return null;
            int mips = texture.mipmapCount - skip;
            var small = new Texture2D(width, height, texture.graphicsFormat, mips, mips > 1 ? TextureCreationFlags.MipChain : TextureCreationFlags.None)
            {
                name = texture.name,
                wrapMode = texture.wrapMode,
                filterMode = texture.filterMode,
                anisoLevel = texture.anisoLevel,
            };
            for (int m = 0; m < mips; m++) Graphics.CopyTexture(texture, 0, skip + m, small, 0, m);
            return small;
        }
    }
}
