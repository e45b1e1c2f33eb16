// Stochastic rasterization, shading stage ("visibility first, shading second"), included by one stage
// file per shading rate (engine/src/techniques/stochastic/shading/, one Rust file each):
//   shade_exact.comp          per pixel, or PER_SAMPLE                         (shading/exact.rs)
//   shade_texture_space.comp  TEXTURE_SPACE: atlas lookups, per pixel or sample (shading/texture_space.rs)
//   shade_decoupled.comp      PER_SAMPLE + DECOUPLED                           (shading/decoupled.rs)
// Each file's permutations are its own axes' product (shaders-glsl/permutations.toml), not every
// rate's times every other axis.
//
// One invocation per pixel reads this pass' samples from the visibility buffer (stochastic/visibility.glsl) and shades
// the hits of one object (pc.object; one dispatch per object, with its set 1 and 2) — the reference's
// rules (engine/src/reference/mod.rs): each sample's own ray, time and barycentrics, recomputed from
// the sample tile and the payload's triangle. Adds (radiance, 1) / S per sample to the frame's
// accumulation image. pc.object == SHADE_BACKGROUND adds the background for the samples without a hit.
//   default:    per-pixel shading: samples of the pixel (in this pass) that hit the same triangle from
//               the same side share the radiance of the first of them (up to SHADE_GROUPS groups per
//               object; later groups are shaded per sample) — how often we shade, never what is
//               visible. Mirrored by the reference's ShadingRate::PerPixel.
//   PER_SAMPLE: every hit shaded.
//   INSTRUMENTED: counts shading evaluations.
//   NO_MOTION / NO_DEFOCUS: as in stochastic.frag.
//   SHADOWS (SHADOW_MSAA, SHADOW_COLOR): lights attenuated by their shadow maps at the sample's
//               surface point (common/shadow.glsl), bound as set 4 — sets 2 and 3 are this
//               technique's. The maps are rendered once per frame: the stochastic frame takes them
//               only when nothing moves in the world (shadows::casters_move).
//   TEXTURE_SPACE: adaptive texture-space shading's pass 2 — each hit looks its radiance up in its
//               object's shading atlas (pass 1, techniques/texture_space.rs) at its shading
//               coordinate and its triangle's level, bilinear, instead of shading: with PER_SAMPLE
//               every hit (the paper's per-sample lookup), without it once per group, at the group's
//               first hit (the paper's per-pixel lookup takes the pixel centre).
//   DECOUPLED:  (with PER_SAMPLE) decoupled shading (stochastic/decoupled.glsl): each hit takes the
//               radiance of its key — (triangle, side, lens-centre pixel cell at mid-shutter) — from
//               a memoization cache, or shades the key's shading point and stores it; or, deferred
//               (pc.decoupled_phase), from a hash table whose new points a dispatch of their own
//               shades between the per-pixel allocation and resolve dispatches.
//   TINTS:      every sample's radiance (or background) times the product of the tints in front of
//               it, from the tint buffer stochastic.frag's tint pass filled (transparency::tint_from_log);
//               per-pixel groups weigh their radiance by the sum of their samples' tints.
#define SHADOW_SET 4
#include "common/object.glsl"
#include "common/shading.glsl"
#include "common/texture_sample.glsl"
#include "stochastic/inside.glsl"
#include "stochastic/push.glsl"
#include "stochastic/visibility.glsl"
#include "stochastic/camera_triangles.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 3, binding = 0, std430) readonly buffer SamplesXyLens { vec4 sample_xy_lens[]; };
layout(set = 3, binding = 1, std430) readonly buffer SamplesTime { float sample_time[]; };
layout(set = 3, binding = 2, std430) buffer Counters {
    uint samples_tested;
    uint samples_hit;
    uint shading_invocations;
    uint fragments;
    // Decoupled shading (shade_decoupled.comp): cache lookups, hits, evictions, stores lost to a race,
    // and (deferred) keys the hash table had no room for.
    uint cache_lookups;
    uint cache_hits;
    uint cache_evictions;
    uint cache_busy;
    uint cache_overflows;
} counters;
layout(set = 3, binding = 6, rgba32f) uniform image2D accum;

const uint SAMPLE_TILE_SIZE = 64u;

#ifdef TINTS
layout(set = 3, binding = 7, std430) readonly buffer TintLog { uint tint_log[]; };
const uint TINT_LOG_ONE = 65536u;        // transparency::TINT_LOG_ONE
const uint TINT_LOG_CAP = 64u * 65536u;  // transparency::TINT_LOG_CAP

float tint_from_log(uint l) {
    return l >= TINT_LOG_CAP ? 0.0 : exp2(-float(l) / float(TINT_LOG_ONE));
}

// The product of the tints in front of what sample i of pixel pix sees.
vec3 sample_tint(uvec2 pix, uint i) {
    uint at = 3u * visibility_index(pix, i, pc.per_pass);
    return vec3(tint_from_log(tint_log[at]), tint_from_log(tint_log[at + 1u]), tint_from_log(tint_log[at + 2u]));
}
#else
vec3 sample_tint(uvec2 pix, uint i) {
    return vec3(1.0);
}
#endif
const uint SHADE_BACKGROUND = 0xffffffffu;
const uint SHADE_GROUPS = 8u;  // engine/src/reference: PER_PIXEL_SHADING_GROUPS

// The sample's ray and the triangle at its time.
struct SampleHit {
    vec3 a, b, c;  // camera space at t
    vec3 ro, rd;
    float t;       // shutter time (the lights')
    uint seg;      // the object's key segment holding t (its index in object_views)
    float s;       // the time within it
};

// Triangle prim at shutter time t (the ray left unset).
SampleHit sample_at_time(uint prim, float t) {
    SampleHit h;
    h.ro = vec3(0.0);
    h.rd = vec3(0.0, 0.0, -1.0);
    h.t = t;
    // KeyTimes::segment_of: the interior keys at or below t.
    uint seg = 0u;
    for (uint j = 1u; j < pc.segment_count; j++) {
        if (object_views[pc.segment_first + j].time.x <= h.t) seg = j;
    }
    h.seg = pc.segment_first + seg;
    h.s = segment_time(object_views[h.seg], h.t);
    vec3 p_open[3], p_close[3];
    load_triangle(prim, seg, pc.segment_count + 1u, p_open, p_close);
    h.a = shutter_lerp(p_open[0], p_close[0], h.s);
    h.b = shutter_lerp(p_open[1], p_close[1], h.s);
    h.c = shutter_lerp(p_open[2], p_close[2], h.s);
    return h;
}

SampleHit sample_at(uint prim, uint tile_index, uvec2 pix) {
    vec4 xl = sample_xy_lens[tile_index];
#ifdef NO_DEFOCUS
    xl.zw = vec2(0.0);
#endif
#ifdef NO_MOTION
    SampleHit h = sample_at_time(prim, 0.5);
#else
    SampleHit h = sample_at_time(prim, sample_time[tile_index]);
#endif
    primary_ray(vec2(pix) + xl.xy, xl.zw, h.ro, h.rd);
    return h;
}

#ifdef TEXTURE_SPACE
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
#endif

// The object's material, loaded once per invocation.
Material object_material;

// Radiance towards the lens of the ray h.rd at barycentrics w of triangle prim at h's time, on its back
// side when `back` (the reference's Tracer::shade_side).
vec3 shade_at(uint prim, SampleHit h, vec3 w, bool back) {
    Vertex tv[3];
    for (uint k = 0u; k < 3u; k++) tv[k] = vertices[indices[3u * prim + k]];
    vec3 geometric = cross(h.b - h.a, h.c - h.a);
    vec3 n = vec3(0.0);
    mat3 n0 = mat3(object_views[h.seg].normal_matrix[0]), n1 = mat3(object_views[h.seg].normal_matrix[1]);
    for (int k = 0; k < 3; k++) {
        vec3 nk = vec3(tv[k].normal[0], tv[k].normal[1], tv[k].normal[2]);
        n += w[k] * mix(n0 * nk, n1 * nk, h.s);
    }
    if (dot(n, n) > 0.0) n = normalize(n);
    else if (dot(geometric, geometric) > 0.0) n = normalize(geometric);
    else n = -h.rd;
    if (back) n = -n;
    vec3 position = w.x * h.a + w.y * h.b + w.z * h.c;
#ifdef SHADOWS
    // The same surface point in object space, for the shadow lookup in the light's own space.
    vec3 object_position = vec3(0.0), object_normal = vec3(0.0);
    for (int k = 0; k < 3; k++) {
        object_position += w[k] * vec3(tv[k].position[0], tv[k].position[1], tv[k].position[2]);
        object_normal += w[k] * vec3(tv[k].normal[0], tv[k].normal[1], tv[k].normal[2]);
    }
    vec3 a = vec3(tv[0].position[0], tv[0].position[1], tv[0].position[2]);
    vec3 b = vec3(tv[1].position[0], tv[1].position[1], tv[1].position[2]);
    vec3 c = vec3(tv[2].position[0], tv[2].position[1], tv[2].position[2]);
    vec3 object_plane = cross(b - a, c - a);
    if (dot(object_normal, object_normal) == 0.0) object_normal = object_plane;
    shadow_receiver = ShadowReceiver(object_position, object_normal, object_plane, h.seg, h.s);
#endif
    vec3 albedo = object_material.albedo_specular.rgb;
    if (object_material.params.y > 0.5) {
        vec2 uv = w.x * vec2(tv[0].uv[0], tv[0].uv[1]) + w.y * vec2(tv[1].uv[0], tv[1].uv[1])
                + w.z * vec2(tv[2].uv[0], tv[2].uv[1]);
        albedo *= texture_bilinear(uv);
    }
    return shade(position, n, -h.rd, albedo, object_material.albedo_specular.w, object_material.params.x, h.t);
}

// Radiance of the sample hitting triangle `prim` (the reference's Tracer::shade_hit).
vec3 shade_hit(uint prim, SampleHit h) {
    // The coverage pass' own test gives the barycentrics; a sample it accepted that rounds out here
    // keeps the plane's.
    float z;
    vec3 w;
    if (!sample_hit(h.a, h.b, h.c, h.ro, h.rd, z, w)) {
        bool ok;
        w = plane_barycentrics(h.a, h.b, h.c, h.ro, h.rd, ok);
    }
#ifdef TEXTURE_SPACE
    return atlas_lookup(prim, w);
#else
    return shade_at(prim, h, w, dot(cross(h.b - h.a, h.c - h.a), h.rd) > 0.0);
#endif
}

#ifdef DECOUPLED
#include "stochastic/decoupled.glsl"
#endif

// Whether a visibility payload names a triangle of this dispatch's object, and which (object-local).
bool is_object_key(uint key) {
    return (key >> 1) - pc.triangle_base < pc.triangle_count;  // unsigned: below the base wraps high
}

uint triangle_of(uint key) {
    return (key >> 1) - pc.triangle_base;
}

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

void main() {
#ifdef DECOUPLED
    // The deferred mode's dispatches that are not per pixel (stochastic/decoupled.glsl).
    if (pc.decoupled_phase == DC_PHASE_ARGS) {
        deferred_args();
        return;
    }
    if (pc.decoupled_phase == DC_PHASE_SHADE) {
        object_material = materials[pc.object];
        deferred_shade_point();
        return;
    }
#endif
    uvec2 pix = gl_GlobalInvocationID.xy + uvec2(pc.origin_x, pc.origin_y);
    if (any(greaterThanEqual(pix, uvec2(view.viewport.xy)))) return;
    float inv_spp = 1.0 / float(pc.spp);
    if (pc.object == SHADE_BACKGROUND) {
        uint empty = 0u;
        vec3 through = vec3(0.0);  // Σ of the empty samples' tints
        for (uint i = 0u; i < pc.per_pass; i++) {
            if (visibility[visibility_index(pix, i, pc.per_pass)] == 0UL) {
                empty++;
                through += sample_tint(pix, i);
            }
        }
        if (empty > 0u) {
            vec4 add = vec4(world.background.rgb * through, float(empty)) * inv_spp;
            imageStore(accum, ivec2(pix), imageLoad(accum, ivec2(pix)) + add);
        }
        return;
    }
    object_material = materials[pc.object];
    uint base = ((pix.y % SAMPLE_TILE_SIZE) * SAMPLE_TILE_SIZE + pix.x % SAMPLE_TILE_SIZE) * pc.spp
              + pc.pass_index * pc.per_pass;
    vec3 sum = vec3(0.0);
    uint count = 0u, shaded = 0u;
#ifdef PER_SAMPLE
    // Per 32 samples: first which are this object's (a cheap loop), then the shading of those only,
    // lowest first — llvmpipe pays a loop body's shading code on every iteration it contains it.
    for (uint chunk = 0u; chunk < pc.per_pass; chunk += 32u) {
        uint mine = 0u;
        uint n = min(32u, pc.per_pass - chunk);
        for (uint j = 0u; j < n; j++) {
            uint64_t v = visibility[visibility_index(pix, chunk + j, pc.per_pass)];
            bool is_mine = v != 0UL && is_object_key(visibility_payload(v));
            mine |= is_mine ? 1u << j : 0u;
        }
        count += uint(bitCount(mine));
#ifdef DECOUPLED
        // Decoupled: first every sample's cache lookup (cheap), then the shading of the misses only —
        // in lock-step lanes a shading inside the lookup loop would be paid on every iteration by
        // every lane whenever one lane missed.
        uint miss = 0u;
        while (mine != 0u) {
            uint j = uint(findLSB(mine));
            mine &= mine - 1u;
            uint at = visibility_index(pix, chunk + j, pc.per_pass);
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
#endif
        while (mine != 0u) {
            uint i = chunk + uint(findLSB(mine));
            mine &= mine - 1u;
            uint payload = visibility_payload(visibility[visibility_index(pix, i, pc.per_pass)]);
            uint prim = triangle_of(payload);
#ifdef DECOUPLED
            sum += sample_tint(pix, i) * decoupled_shade(prim, payload, sample_at(prim, base + i, pix));
#else
            sum += sample_tint(pix, i) * shade_hit(prim, sample_at(prim, base + i, pix));
            shaded++;
#endif
        }
    }
#else
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
    for (uint i = 0u; i < pc.per_pass; i++) {
        uint64_t v = visibility[visibility_index(pix, i, pc.per_pass)];
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
    for (uint i = 0u; overflow && i < pc.per_pass; i++) {
        uint64_t v = visibility[visibility_index(pix, i, pc.per_pass)];
        uint payload = visibility_payload(v);
        uint key = payload;
        bool grouped = any(equal(key_lo, uvec4(key))) || any(equal(key_hi, uvec4(key)));
        if (v != 0UL && is_object_key(payload) && !grouped) {
            uint prim = triangle_of(key);
            sum += sample_tint(pix, i) * shade_hit(prim, sample_at(prim, base + i, pix));
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
        sum += weight * shade_hit(prim, sample_at(prim, base + first, pix));
        shaded++;
    }
#endif
#ifdef DECOUPLED
    if (pc.decoupled_phase == DC_PHASE_ALLOCATE) count = 0u;  // adds nothing
#endif
    if (count > 0u) {
        vec4 add = vec4(sum, float(count)) * inv_spp;
        imageStore(accum, ivec2(pix), imageLoad(accum, ivec2(pix)) + add);
    }
#ifdef INSTRUMENTED
    if (shaded > 0u) atomicAdd(counters.shading_invocations, shaded);
#endif
}
