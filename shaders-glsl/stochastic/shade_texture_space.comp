#version 460
// The stochastic shading stage of adaptive texture-space shading, pass 2
// (engine/src/techniques/stochastic/shading/texture_space.rs): each hit looks its radiance up in its
// object's shading atlas (pass 1, techniques/texture_space.rs) at its shading coordinate and its
// triangle's level, bilinear, instead of shading: with PER_SAMPLE every hit (the paper's per-sample
// lookup), without it once per group, at the group's first hit (the paper's per-pixel lookup takes the
// pixel centre) — the loops of stochastic/shade_loops.glsl. Nothing is shaded here, so the shadow-map
// axes are pass 1's (texture_space/atlas.frag), not this file's.
#include "stochastic/shade_push.glsl"

// TextureSpacePush (shading/texture_space.rs).
layout(push_constant) uniform Push {
    ShadePush shade;
    // The object's atlas layout (texture_space::atlas::MipAtlas): level 0's side and the gutter.
    uint atlas_finest;
    uint atlas_gutter;
} pc;

#include "stochastic/shade.glsl"

// Set 2 (STOCHASTIC_OBJECT_SET): the object's shading atlas, each triangle's level (levels.comp's
// layout: radius, spacing, level, valid) and each corner's shading coordinate in texels of level 0.
layout(set = 2, binding = 5) uniform sampler2D atlas;
layout(set = 2, binding = 6, std430) readonly buffer AtlasLevels { vec4 atlas_levels[]; };
layout(set = 2, binding = 7, std430) readonly buffer AtlasCoords { vec2 atlas_coords[]; };

// MipAtlas::level_rect's corner.
vec2 atlas_level_offset(uint level) {
    if (level == 0u) return vec2(0.0);
    uint y = 0u;
    for (uint k = 1u; k < level; k++) y += (pc.atlas_finest >> k) + pc.atlas_gutter;
    return vec2(float(pc.atlas_finest + pc.atlas_gutter), float(y));
}

// The shaded radiance at barycentrics w of triangle prim: a bilinear lookup at its level.
vec3 atlas_lookup(uint prim, vec3 w) {
    uint level = uint(atlas_levels[prim].z);
    vec2 t = w.x * atlas_coords[3u * prim] + w.y * atlas_coords[3u * prim + 1u] + w.z * atlas_coords[3u * prim + 2u];
    vec2 p = t / float(1u << level) + atlas_level_offset(level) - 0.5;
    vec2 p0 = floor(p);
    vec2 f = p - p0;
    ivec2 size = textureSize(atlas, 0);
    ivec2 i0 = clamp(ivec2(p0), ivec2(0), size - 1), i1 = clamp(ivec2(p0) + 1, ivec2(0), size - 1);
    vec3 a = texelFetch(atlas, ivec2(i0.x, i0.y), 0).rgb;
    vec3 b = texelFetch(atlas, ivec2(i1.x, i0.y), 0).rgb;
    vec3 c = texelFetch(atlas, ivec2(i0.x, i1.y), 0).rgb;
    vec3 d = texelFetch(atlas, ivec2(i1.x, i1.y), 0).rgb;
    return mix(mix(a, b, f.x), mix(c, d, f.x), f.y);
}

vec3 hit_radiance(uint prim, SampleHit h) {
    return atlas_lookup(prim, hit_barycentrics(h));
}

#include "stochastic/shade_loops.glsl"

void main() {
    uvec2 pix;
    if (!shade_begin(pix)) return;
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
