// The exact and texture-space shading stages' loops over the object's hits in a pixel
// (shade_exact.comp, shade_texture_space.comp), on shade.glsl and the stage's own
// hit_radiance(prim, h) — the radiance of one hit, shaded or looked up:
//   shade_each_sample (PER_SAMPLE): every hit.
//   shade_groups (per pixel): samples of the pixel (in this pass) that hit the same triangle from the
//               same side share the radiance of the first of them (up to SHADE_GROUPS groups per
//               object; later groups are evaluated per sample) — how often we shade, never what is
//               visible. Mirrored by the reference's ShadingRate::PerPixel.
// Both add each hit's radiance times its tint (TINTS) to `sum`, the object's samples to `count` and
// the evaluations to `shaded` (shade_end takes the three).
#ifndef SHUTTER_STOCHASTIC_SHADE_LOOPS_GLSL
#define SHUTTER_STOCHASTIC_SHADE_LOOPS_GLSL

// The stage's.
vec3 hit_radiance(uint prim, SampleHit h);

const uint SHADE_GROUPS = 8u;  // engine/src/reference: PER_PIXEL_SHADING_GROUPS

// Component g (0..8) of the pair (lo, hi), by selects rather than a variable index.
uint pick(uvec4 lo, uvec4 hi, uint g) {
    uvec4 v = g < 4u ? lo : hi;
    uint k = g & 3u;
    return k == 0u ? v.x : (k == 1u ? v.y : (k == 2u ? v.z : v.w));
}

float pickf(vec4 lo, vec4 hi, uint g) {
    vec4 v = g < 4u ? lo : hi;
    uint k = g & 3u;
    return k == 0u ? v.x : (k == 1u ? v.y : (k == 2u ? v.z : v.w));
}

void shade_each_sample(uvec2 pix, uint base, inout vec3 sum, inout uint count, inout uint shaded) {
    // Per 32 samples: first which are this object's (a cheap loop), then the shading of those only,
    // lowest first — llvmpipe pays a loop body's shading code on every iteration it contains it.
    for (uint chunk = 0u; chunk < pc.shade.per_pass; chunk += 32u) {
        uint mine = object_samples(pix, chunk);
        count += uint(bitCount(mine));
        while (mine != 0u) {
            uint i = chunk + uint(findLSB(mine));
            mine &= mine - 1u;
            uint payload = visibility_payload(visibility[visibility_index(pix, i, pc.shade.per_pass)]);
            uint prim = triangle_of(payload);
            sum += sample_tint(pix, i) * hit_radiance(prim, sample_at(prim, base + i, pix));
            shaded++;
        }
    }
}

void shade_groups(uvec2 pix, uint base, inout vec3 sum, inout uint count, inout uint shaded) {
    // Two phases, so that SIMD lanes (llvmpipe runs 8 pixels in lock-step) shade together: first the
    // pixel's groups — (triangle, side), the first sample of each, how many samples it stands for —
    // then one shading per group. Samples beyond SHADE_GROUPS groups are shaded on their own. The
    // groups live in vectors read by selects: llvmpipe keeps a dynamically indexed local array in
    // memory, which cost more than all the shading.
    const uint NO_KEY = 0xffffffffu;
    uvec4 key_lo = uvec4(NO_KEY), key_hi = uvec4(NO_KEY);
    uvec4 first_lo = uvec4(0u), first_hi = uvec4(0u);
    uvec4 count_lo = uvec4(0u), count_hi = uvec4(0u);
#ifdef TINTS
    // Per group and channel: Σ of its samples' tints (the weight of its radiance).
    vec4 tr_lo = vec4(0.0), tr_hi = vec4(0.0), tg_lo = vec4(0.0), tg_hi = vec4(0.0);
    vec4 tb_lo = vec4(0.0), tb_hi = vec4(0.0);
#endif
    uint groups = 0u;
    bool overflow = false;
    // Branch-free but for the rare overflow: llvmpipe pays every branch's masking per sample.
    for (uint i = 0u; i < pc.shade.per_pass; i++) {
        uint64_t v = visibility[visibility_index(pix, i, pc.shade.per_pass)];
        uint payload = visibility_payload(v);
        bool mine = v != 0UL && is_object_key(payload);
        uint key = payload;  // the group: the triangle and the side its ray sees
        uvec4 m = uvec4(mine ? 1u : 0u);
        uvec4 in_lo = uvec4(equal(key_lo, uvec4(key))) & m, in_hi = uvec4(equal(key_hi, uvec4(key))) & m;
        bool found = any(bvec4(in_lo | in_hi));
        bool insert = mine && !found && groups < SHADE_GROUPS;
        uvec4 ins = uvec4(insert ? 1u : 0u);
        uvec4 at_lo = uvec4(equal(uvec4(groups), uvec4(0u, 1u, 2u, 3u))) & ins;
        uvec4 at_hi = uvec4(equal(uvec4(groups), uvec4(4u, 5u, 6u, 7u))) & ins;
        key_lo = mix(key_lo, uvec4(key), bvec4(at_lo));
        key_hi = mix(key_hi, uvec4(key), bvec4(at_hi));
        first_lo = mix(first_lo, uvec4(i), bvec4(at_lo));
        first_hi = mix(first_hi, uvec4(i), bvec4(at_hi));
        count_lo += in_lo + at_lo;
        count_hi += in_hi + at_hi;
#ifdef TINTS
        vec3 tint = sample_tint(pix, i);
        vec4 g_lo = vec4(in_lo + at_lo), g_hi = vec4(in_hi + at_hi);
        tr_lo += g_lo * tint.r;
        tr_hi += g_hi * tint.r;
        tg_lo += g_lo * tint.g;
        tg_hi += g_hi * tint.g;
        tb_lo += g_lo * tint.b;
        tb_hi += g_hi * tint.b;
#endif
        groups += insert ? 1u : 0u;
        count += mine ? 1u : 0u;
        overflow = overflow || (mine && !found && !insert);
    }
    // Samples of groups past SHADE_GROUPS, each on its own (rare: kept out of the loop above, whose
    // every iteration llvmpipe would otherwise pay for the shading code).
    for (uint i = 0u; overflow && i < pc.shade.per_pass; i++) {
        uint64_t v = visibility[visibility_index(pix, i, pc.shade.per_pass)];
        uint payload = visibility_payload(v);
        uint key = payload;
        bool grouped = any(equal(key_lo, uvec4(key))) || any(equal(key_hi, uvec4(key)));
        if (v != 0UL && is_object_key(payload) && !grouped) {
            uint prim = triangle_of(key);
            sum += sample_tint(pix, i) * hit_radiance(prim, sample_at(prim, base + i, pix));
            shaded++;
        }
    }
    for (uint g = 0u; g < groups; g++) {
        uint prim = triangle_of(pick(key_lo, key_hi, g));
        uint first = pick(first_lo, first_hi, g);
#ifdef TINTS
        vec3 weight = vec3(pickf(tr_lo, tr_hi, g), pickf(tg_lo, tg_hi, g), pickf(tb_lo, tb_hi, g));
#else
        vec3 weight = vec3(float(pick(count_lo, count_hi, g)));
#endif
        sum += weight * hit_radiance(prim, sample_at(prim, base + first, pix));
        shaded++;
    }
}

#endif
