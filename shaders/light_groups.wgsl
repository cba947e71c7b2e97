// The light density's groups (`lights::LightTables`): a mesh's faces are one
// object of the uniform pick, a face within it picked by power through an alias
// table. The sampling and density over them are generated (`kernel::glue`).

// Mirrors `lights::LightGroup`: `count` lights from `first` on.
struct LightGroup {
    first: u32,
    count: u32,
}

// Mirrors `lights::LightPick`: one alias-table slot (below `threshold` the
// slot's own light, above it `other`, both within the group) and the
// probability of the light of the same index within its group.
struct LightPick {
    threshold: f32,
    other: u32,
    pmf: f32,
}

// Mirrors `lights::LightRef`: a leaf entry of the light BVH, a light and its
// probability within its group, read by the density's walk in one load.
struct LightRef {
    light: u32,
    pmf: f32,
}
