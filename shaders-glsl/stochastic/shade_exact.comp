#version 460
// The stochastic shading stage at the exact rates (engine/src/techniques/stochastic/shading/exact.rs):
// every hit shaded from its own sample (PER_SAMPLE), or once per (triangle, side) group of the pixel
// (stochastic/shade_loops.glsl); the shading itself is shade.glsl's shade_hit.
#include "stochastic/shade_push.glsl"

// ExactPush (shading/exact.rs): the shading stages' common fields only.
layout(push_constant) uniform Push {
    ShadePush shade;
} pc;

#include "stochastic/shade.glsl"

vec3 hit_radiance(uint prim, SampleHit h) {
    return shade_hit(prim, h);
}

#include "stochastic/shade_loops.glsl"

void main() {
    uvec2 pix;
    if (!shade_begin(pix)) return;
    object_material = materials[pc.shade.object];
    uint base = sample_base(pix);
    vec3 sum = vec3(0.0);
    uint count = 0u, shaded = 0u;
#ifdef PER_SAMPLE
    shade_each_sample(pix, base, sum, count, shaded);
#else
    shade_groups(pix, base, sum, count, shaded);
#endif
    shade_end(pix, sum, count, shaded);
}
