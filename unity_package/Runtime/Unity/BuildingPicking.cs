// Which building a raycast hit: a streamed or imported building (its BuildingAttributes, on the
// building's root above the hit collider) or a tile proxy (its ProxyBuildings, above the hit
// MeshCollider, and the hit triangle's first vertex's owner). Colliders are the user's or, for
// proxies, VWorldLodStreamer.proxyColliders'; see the package docs ("Picking a building").
using UnityEngine;

namespace VWorldLod
{
    public static class BuildingPicking
    {
        /// <summary>
        /// True with the hit building's tile (its tile root's VWorldLodTilePlacement.tileName,
        /// "" without one) and id; false when the hit is on neither a building nor
        /// a proxy with features. On a proxy the collider must be a MeshCollider on its mesh (the
        /// triangle index is Unity's only then).
        /// </summary>
        public static bool Resolve(RaycastHit hit, out string tile, out string buildingId)
        {
            BuildingAttribute[] attributes;
            return Resolve(hit, out tile, out buildingId, out attributes);
        }

        /// <summary>
        /// Resolve, with the building's attributes: a building level's BuildingAttributes.attributes;
        /// on a proxy the record's values for it (its source attributes and id, source_id,
        /// source_file, height, as the 3D Tiles metadata has them).
        /// </summary>
        public static bool Resolve(RaycastHit hit, out string tile, out string buildingId, out BuildingAttribute[] attributes)
        {
            tile = buildingId = null;
            attributes = null;
            Collider collider = hit.collider;
            if (collider == null) return false;
            BuildingAttributes building = collider.GetComponentInParent<BuildingAttributes>();
            if (building != null)
            {
                VWorldLodTilePlacement root = building.GetComponentInParent<VWorldLodTilePlacement>();
                tile = root != null ? root.tileName : "";
                buildingId = building.buildingId;
                attributes = building.attributes.ToArray();
                return true;
            }
            ProxyBuildings proxy = collider.GetComponentInParent<ProxyBuildings>();
            var mesh = collider as MeshCollider;
            if (proxy == null || mesh == null || mesh.sharedMesh == null) return false;
            return proxy.Resolve(mesh.sharedMesh.triangles, hit.triangleIndex, out tile, out buildingId, out attributes);
        }
    }
}
