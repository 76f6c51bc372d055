// One glTF level loaded at run time: its GameObject (inactive until shown) and the glTFast import
// that owns its meshes, materials and textures (disposing it frees them).
using GLTFast;
using UnityEngine;

namespace VWorldLod
{
    public class LoadedLevel
    {
        public readonly GameObject Root;
        public readonly GltfImport Import;

        public LoadedLevel(GameObject root, GltfImport import)
        {
            Root = root;
            Import = import;
        }

        public Renderer[] Renderers { get { return Root.GetComponentsInChildren<Renderer>(true); } }

        /// <summary>Destroys the GameObject and frees the imported resources.</summary>
        public void Release()
        {
            if (Root != null) Object.Destroy(Root);
            Import.Dispose();
        }
    }
}
