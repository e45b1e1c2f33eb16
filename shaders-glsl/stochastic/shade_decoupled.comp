#version 460
// The stochastic shading stage of decoupled shading
// (engine/src/techniques/stochastic/shading/decoupled.rs, stochastic/decoupled.glsl): per sample, each
// hit takes the radiance of its key — (triangle, side, lens-centre pixel cell at mid-shutter) — from a
// memoization cache, or shades the key's shading point and stores it; or, deferred
// (pc.decoupled_phase), from a hash table whose new points a dispatch of their own shades between the
// per-pixel allocation and resolve dispatches.
#include "stochastic/shade_push.glsl"

// DecoupledPush (shading/decoupled.rs).
layout(push_constant) uniform Push {
    ShadePush shade;
    // Entries of the memoization cache or of the deferred mode's hash table.
    uint cache_entries;
    // The dispatch's phase (DC_PHASE_* in stochastic/decoupled.glsl; shading::DecoupledPhase).
    uint decoupled_phase;
} pc;

#include "stochastic/shade.glsl"
#include "stochastic/decoupled.glsl"

void main() {
    // The deferred mode's dispatches that are not per pixel (stochastic/decoupled.glsl).
    if (pc.decoupled_phase == DC_PHASE_ARGS) {
        deferred_args();
        return;
    }
    if (pc.decoupled_phase == DC_PHASE_SHADE) {
        object_material = materials[pc.shade.object];
        deferred_shade_point();
        return;
    }
    uvec2 pix;
    if (!shade_begin(pix)) return;
    object_material = materials[pc.shade.object];
    uint base = sample_base(pix);
    vec3 sum = vec3(0.0);
    uint count = 0u;
    // Per 32 samples: first which are this object's (a cheap loop), then every sample's cache lookup
    // (cheap), then the shading of the misses only, lowest first — llvmpipe pays a loop body's shading
    // code on every iteration it contains it, and in lock-step lanes a shading inside the lookup loop
    // would be paid on every iteration by every lane whenever one lane missed.
    for (uint chunk = 0u; chunk < pc.shade.per_pass; chunk += 32u) {
        uint mine = object_samples(pix, chunk);
        count += uint(bitCount(mine));
        uint miss = 0u;
        while (mine != 0u) {
            uint j = uint(findLSB(mine));
            mine &= mine - 1u;
            uint at = visibility_index(pix, chunk + j, pc.shade.per_pass);
            uint payload = visibility_payload(visibility[at]);
            uint prim = triangle_of(payload);
            vec3 v = vec3(0.0);
            bool hit;
            if (pc.decoupled_phase == DC_PHASE_ALLOCATE) {
                // The deferred mode's first dispatch: each sample's entry, nothing added.
                refs[at] = deferred_allocate(prim, payload, sample_at(prim, base + chunk + j, pix));
                hit = true;
            } else if (pc.decoupled_phase == DC_PHASE_RESOLVE) {
                uint ref = refs[at];
                hit = ref != DC_SHADE_HERE;
                if (hit) v = deferred_value(ref);
            } else {
                hit = decoupled_lookup(prim, payload, sample_at(prim, base + chunk + j, pix), v);
            }
            sum += hit ? sample_tint(pix, chunk + j) * v : vec3(0.0);
            miss |= hit ? 0u : 1u << j;
        }
        mine = miss;
        while (mine != 0u) {
            uint i = chunk + uint(findLSB(mine));
            mine &= mine - 1u;
            uint payload = visibility_payload(visibility[visibility_index(pix, i, pc.shade.per_pass)]);
            uint prim = triangle_of(payload);
            sum += sample_tint(pix, i) * decoupled_shade(prim, payload, sample_at(prim, base + i, pix));
        }
    }
    if (pc.decoupled_phase == DC_PHASE_ALLOCATE) count = 0u;  // adds nothing
    // decoupled.glsl counts its own shadings.
    shade_end(pix, sum, count, 0u);
}
