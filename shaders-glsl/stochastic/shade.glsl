// Stochastic rasterization, shading stage ("visibility first, shading second"): what every stage file
// shares, one per shading rate (engine/src/techniques/stochastic/shading/, one Rust file each):
//   shade_exact.comp          per pixel, or PER_SAMPLE; its loops in shade_loops.glsl  (shading/exact.rs)
//   shade_texture_space.comp  atlas lookups, per pixel or PER_SAMPLE; shade_loops.glsl (shading/texture_space.rs)
//   shade_decoupled.comp      per sample, memoization cache or deferred (decoupled.glsl) (shading/decoupled.rs)
// Each file declares its own push constants (`pc`: ShadePush `shade` first, shade_push.glsl, then its
// own fields) before including this, and has its own axes (shaders-glsl/permutations.toml).
//
// One invocation per pixel reads this pass' samples from the visibility buffer (stochastic/visibility.glsl) and shades
// the hits of one object (pc.shade.object; one dispatch per object, with its set 1 and 2) — the reference's
// rules (engine/src/reference/mod.rs): each sample's own ray, time and barycentrics, recomputed from
// the sample tile and the payload's triangle. Adds (radiance, 1) / S per sample to the frame's
// accumulation image (shade_end). pc.shade.object == SHADE_BACKGROUND adds the background for the
// samples without a hit (shade_begin).
//   INSTRUMENTED: counts shading evaluations.
//   NO_MOTION / NO_DEFOCUS: as in stochastic.frag.
//   SHADOWS (SHADOW_MSAA, SHADOW_COLOR): lights attenuated by their shadow maps at the sample's
//               surface point (common/shadow.glsl), bound as set 4 — sets 2 and 3 are this
//               technique's. The maps are rendered once per frame: the stochastic frame takes them
//               only when nothing moves in the world (shadows::casters_move).
//   TINTS:      every sample's radiance (or background) times the product of the tints in front of
//               it, from the tint buffer stochastic.frag's tint pass filled (transparency::tint_from_log);
//               per-pixel groups weigh their radiance by the sum of their samples' tints.
#ifndef SHUTTER_STOCHASTIC_SHADE_GLSL
#define SHUTTER_STOCHASTIC_SHADE_GLSL
#define SHADOW_SET 4
#include "common/object.glsl"
#include "common/shading.glsl"
#include "common/texture_sample.glsl"
#include "stochastic/inside.glsl"
#include "stochastic/visibility.glsl"
#include "stochastic/camera_triangles.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

#include "stochastic/sample_tile.glsl"
layout(set = 3, binding = 6, rgba32f) uniform image2D accum;

#ifdef TINTS
layout(set = 3, binding = 7, std430) readonly buffer TintLog { uint tint_log[]; };
const uint TINT_LOG_ONE = 65536u;        // transparency::TINT_LOG_ONE
const uint TINT_LOG_CAP = 64u * 65536u;  // transparency::TINT_LOG_CAP

float tint_from_log(uint l) {
    return l >= TINT_LOG_CAP ? 0.0 : exp2(-float(l) / float(TINT_LOG_ONE));
}

// The product of the tints in front of what sample i of pixel pix sees.
vec3 sample_tint(uvec2 pix, uint i) {
    uint at = 3u * visibility_index(pix, i, pc.shade.per_pass);
    return vec3(tint_from_log(tint_log[at]), tint_from_log(tint_log[at + 1u]), tint_from_log(tint_log[at + 2u]));
}
#else
vec3 sample_tint(uvec2 pix, uint i) {
    return vec3(1.0);
}
#endif
const uint SHADE_BACKGROUND = 0xffffffffu;  // shading::SHADE_BACKGROUND

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
    for (uint j = 1u; j < pc.shade.segment_count; j++) {
        if (object_views[pc.shade.segment_first + j].time.x <= h.t) seg = j;
    }
    h.seg = pc.shade.segment_first + seg;
    h.s = segment_time(object_views[h.seg], h.t);
    vec3 p_open[3], p_close[3];
    load_triangle(prim, seg, pc.shade.segment_count + 1u, p_open, p_close);
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

// The barycentrics of the sample's hit on triangle (h.a, h.b, h.c): the coverage pass' own test gives
// them; a sample it accepted that rounds out here keeps the plane's.
vec3 hit_barycentrics(SampleHit h) {
    float z;
    vec3 w;
    if (!sample_hit(h.a, h.b, h.c, h.ro, h.rd, z, w)) {
        bool ok;
        w = plane_barycentrics(h.a, h.b, h.c, h.ro, h.rd, ok);
    }
    return w;
}

// Radiance of the sample hitting triangle `prim` (the reference's Tracer::shade_hit).
vec3 shade_hit(uint prim, SampleHit h) {
    vec3 w = hit_barycentrics(h);
    return shade_at(prim, h, w, dot(cross(h.b - h.a, h.c - h.a), h.rd) > 0.0);
}

// Whether a visibility payload names a triangle of this dispatch's object, and which (object-local).
bool is_object_key(uint key) {
    return (key >> 1) - pc.shade.triangle_base < pc.shade.triangle_count;  // unsigned: below the base wraps high
}

uint triangle_of(uint key) {
    return (key >> 1) - pc.shade.triangle_base;
}

// The invocation's pixel; false when nothing is left to do: outside the viewport, or the background
// dispatch (pc.shade.object == SHADE_BACKGROUND), done here — the samples without a hit add the
// background (times their tints).
bool shade_begin(out uvec2 pix) {
    pix = gl_GlobalInvocationID.xy + uvec2(pc.shade.origin_x, pc.shade.origin_y);
    if (any(greaterThanEqual(pix, uvec2(view.viewport.xy)))) return false;
    if (pc.shade.object != SHADE_BACKGROUND) return true;
    float inv_spp = 1.0 / float(pc.shade.spp);
    uint empty = 0u;
    vec3 through = vec3(0.0);  // Σ of the empty samples' tints
    for (uint i = 0u; i < pc.shade.per_pass; i++) {
        if (visibility[visibility_index(pix, i, pc.shade.per_pass)] == 0UL) {
            empty++;
            through += sample_tint(pix, i);
        }
    }
    if (empty > 0u) {
        vec4 add = vec4(world.background.rgb * through, float(empty)) * inv_spp;
        imageStore(accum, ivec2(pix), imageLoad(accum, ivec2(pix)) + add);
    }
    return false;
}

// The sample tile's index of the pixel's first sample of this pass.
uint sample_base(uvec2 pix) {
    return ((pix.y % SAMPLE_TILE_SIZE) * SAMPLE_TILE_SIZE + pix.x % SAMPLE_TILE_SIZE) * pc.shade.spp
         + pc.shade.pass_index * pc.shade.per_pass;
}

// Which of the pass' samples chunk .. chunk + 31 of the pixel hit this dispatch's object: bit j for
// sample chunk + j (the per-sample loops' cheap first step).
uint object_samples(uvec2 pix, uint chunk) {
    uint mine = 0u;
    uint n = min(32u, pc.shade.per_pass - chunk);
    for (uint j = 0u; j < n; j++) {
        uint64_t v = visibility[visibility_index(pix, chunk + j, pc.shade.per_pass)];
        bool is_mine = v != 0UL && is_object_key(visibility_payload(v));
        mine |= is_mine ? 1u << j : 0u;
    }
    return mine;
}

// Adds the object's `count` samples of the pixel, whose radiance (times their tints) sums to `sum`:
// (sum, count) / S; counts `shaded` shading evaluations (INSTRUMENTED).
void shade_end(uvec2 pix, vec3 sum, uint count, uint shaded) {
    float inv_spp = 1.0 / float(pc.shade.spp);
    if (count > 0u) {
        vec4 add = vec4(sum, float(count)) * inv_spp;
        imageStore(accum, ivec2(pix), imageLoad(accum, ivec2(pix)) + add);
    }
#ifdef INSTRUMENTED
    if (shaded > 0u) atomicAdd(counters.shading_invocations, shaded);
#endif
}

#endif
