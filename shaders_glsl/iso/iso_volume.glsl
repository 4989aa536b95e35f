//! iso_volume.glsl — the sparse lattice of the smoothed iso field (`[iso] smoothing` > 0): voxels of
//! `[iso] voxel` radii in bricks of ISO_VOLUME_BRICK³ (8³), allocated only where particles reach. A dense
//! table over the lattice's box at brick resolution holds, per brick, 0 (no brick: every value there is 0), its
//! index in the pool + 1, or ISO_UNSTORED; the pool holds the allocated bricks' voxels, x fastest within a
//! brick. Shared by iso_volume.comp (mark, allocate, deposit) and the cast (iso_field.glsl with ISO_VOLUME).
//! CPU reference: VolumeShape in src/field/iso/mod.rs.
//! The including shader defines ISO_TABLE(i) → uint, the table's entry i.

#define ISO_STORE_VOXELS (ISO_STORE * ISO_STORE * ISO_STORE)
const uint ISO_NONE = 0xffffffffu;
/// A table entry for a marked brick the pool had no room for (iso_volume's ALLOC): read as 0 like an unmarked
/// brick, but not empty space (points are near it), so the cast does not skip through it.
const uint ISO_UNSTORED = 0xffffffffu;

/// Brick b's table entry (`bd` bricks per axis): 0 (unmarked), its pool index + 1, or ISO_UNSTORED — also
/// outside the table, where every value is 0 but nothing is known to be empty.
uint iso_brick_entry(ivec3 b, ivec3 bd) {
    if (any(lessThan(b, ivec3(0))) || any(greaterThanEqual(b, bd))) return ISO_UNSTORED;
    return ISO_TABLE(b.x + bd.x * (b.y + bd.y * b.z));
}

/// The pool index of the first stored voxel of the brick with table entry e, or ISO_NONE where none is stored.
uint iso_entry_base(uint e) { return e == 0u || e == ISO_UNSTORED ? ISO_NONE : (e - 1u) * uint(ISO_STORE_VOXELS); }

/// The pool index of brick b's first stored voxel, or ISO_NONE where no brick is allocated (or b is outside
/// the table).
uint iso_brick_base(ivec3 b, ivec3 bd) { return iso_entry_base(iso_brick_entry(b, bd)); }

/// Index within a stored brick of storage coordinate t (0 … 9; the brick's own voxels at 1 … 8).
int iso_store_index(ivec3 t) { return t.x + ISO_STORE * (t.y + ISO_STORE * t.z); }

/// The pool index of voxel g (lattice coordinates) in its own brick, or ISO_NONE (its value is 0).
uint iso_voxel_slot(ivec3 g, ivec3 bd) {
    uint base = iso_brick_base(g >> 3, bd);
    if (base == ISO_NONE) return ISO_NONE;
    return base + uint(iso_store_index((g & 7) + 1));
}
