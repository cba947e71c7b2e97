//! The stages a profiling kernel counts (`KernelConfig::profile`,
//! `shaders/profile.wgsl`, `pathmix bench --stages`). The megakernel runs a
//! whole path per invocation, so a stage's time cannot be read off a clock;
//! what is counted is the work each stage does per path and how much of each
//! SIMD vector does it: at a stage, the SIMD group (subgroup) running it adds
//! its active lanes and its width. Lanes a group runs masked off are what a
//! divergent scene costs beyond its work.

/// A stage of the path loop that the profiling kernel counts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stage {
    /// One step of a path: its closest hit, and what is done there.
    PathStep,
    /// A node of the scene's BVH visited by a closest-hit walk.
    ClosestNodes,
    /// A primitive of a BVH leaf tested by a closest-hit walk.
    ClosestPrimitives,
    /// A node visited by a shadow ray's walk (next-event estimation, point
    /// and spot lights, masks).
    ShadowNodes,
    /// A primitive tested by a shadow ray's walk.
    ShadowPrimitives,
    /// Texture lookups: colours, opacities, bump and normal maps.
    Textures,
    /// Sampling the material (and the light, with its shadow ray's weight).
    Shading,
}

impl Stage {
    /// In the order of their indices in the counts. A walk's primitive tests
    /// come right after its node visits: `shaders/profile.wgsl` counts them
    /// one index on.
    pub const ALL: [Stage; 7] = [
        Stage::PathStep,
        Stage::ClosestNodes,
        Stage::ClosestPrimitives,
        Stage::ShadowNodes,
        Stage::ShadowPrimitives,
        Stage::Textures,
        Stage::Shading,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Stage::PathStep => "path steps",
            Stage::ClosestNodes => "closest-hit node visits",
            Stage::ClosestPrimitives => "closest-hit primitive tests",
            Stage::ShadowNodes => "shadow-ray node visits",
            Stage::ShadowPrimitives => "shadow-ray primitive tests",
            Stage::Textures => "texture lookups",
            Stage::Shading => "material and light sampling",
        }
    }

    /// Its WGSL constant (`glue::shared_constants`).
    pub fn constant(self) -> &'static str {
        match self {
            Stage::PathStep => "STAGE_PATH_STEP",
            Stage::ClosestNodes => "STAGE_CLOSEST_NODES",
            Stage::ClosestPrimitives => "STAGE_CLOSEST_PRIMITIVES",
            Stage::ShadowNodes => "STAGE_SHADOW_NODES",
            Stage::ShadowPrimitives => "STAGE_SHADOW_PRIMITIVES",
            Stage::Textures => "STAGE_TEXTURES",
            Stage::Shading => "STAGE_SHADING",
        }
    }

    pub fn index(self) -> u32 {
        Stage::ALL.iter().position(|&s| s == self).unwrap() as u32
    }
}
