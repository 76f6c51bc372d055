// Caps a loaded proxy's textures at maxTextureSize texels a side (ProxyStreamer asks for it by
// the proxy's size on screen): glTFast has no such import setting (its ImportSettings hold mipmap
// generation, filters and anisotropy only), so after the load each larger Texture2D with a mip
// chain is replaced by a smaller one holding its mip levels from the first that fits, copied on
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
        /// Replaces, in the renderers' materials, every Texture2D wider or taller than
        /// maxTextureSize (texels; 0: none) by its mip levels from the first that fits; returns
        /// the textures made (the caller destroys them with the proxy).
        /// </summary>
        public static List<Texture2D> Apply(Renderer[] renderers, int maxTextureSize)
        {
            var made = new List<Texture2D>();
            if (maxTextureSize <= 0 || SystemInfo.copyTextureSupport == CopyTextureSupport.None) return made;
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
                            small = Smaller(texture, maxTextureSize);
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

        // texture's mip levels from the first at most maxTextureSize a side, or null (it fits, or has no mips to drop).
        static Texture2D Smaller(Texture2D texture, int maxTextureSize)
        {
            int skip = 0, width = texture.width, height = texture.height;
            while (skip < texture.mipmapCount - 1 && System.Math.Max(width, height) > maxTextureSize)
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
