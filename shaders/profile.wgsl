// A profiling kernel's stage counts (`KernelConfig::profile`, src/kernel/profile.rs):
// at each stage the kernel marks, the SIMD group (subgroup) running it adds its
// active lanes and its width, so lanes over slots is the share of the vector
// doing the stage's work.

// Mirrors `abi::StageCounts`: 64-bit counts in two words each.
struct StageCounts {
    lanes_low: atomic<u32>,
    lanes_high: atomic<u32>,
    slots_low: atomic<u32>,
    slots_high: atomic<u32>,
}

@group(0) @binding(BINDING_PROFILE) var<storage, read_write> stage_counts: array<StageCounts, PROFILE_STAGES>;

// The subgroup's width (`render` sets it), and the stage a BVH walk's node
// visits count toward: STAGE_CLOSEST_NODES or STAGE_SHADOW_NODES (its
// primitive tests toward the next stage).
var<private> profile_subgroup_size: u32;
var<private> profile_walk: u32;

fn profile(stage: u32) {
    let lanes = subgroupAdd(1u);
    // The group's first active lane counts for it.
    if subgroupExclusiveAdd(1u) == 0u {
        if atomicAdd(&stage_counts[stage].lanes_low, lanes) > 0xffffffffu - lanes {
            atomicAdd(&stage_counts[stage].lanes_high, 1u);
        }
        if atomicAdd(&stage_counts[stage].slots_low, profile_subgroup_size) > 0xffffffffu - profile_subgroup_size {
            atomicAdd(&stage_counts[stage].slots_high, 1u);
        }
    }
}
