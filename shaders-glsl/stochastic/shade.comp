#version 460
// Stochastic rasterization, shading stage ("visibility first, shading second"): one invocation per
// pixel reads this pass' samples from the visibility buffer (stochastic/visibility.glsl) and shades
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
#include "common/object.glsl"
#include "common/shading.glsl"
#include "stochastic/inside.glsl"
#include "stochastic/push.glsl"
#include "stochastic/visibility.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 2, binding = 0, std430) readonly buffer Triangles { float triangles[]; };
layout(set = 3, binding = 0, std430) readonly buffer SamplesXyLens { vec4 sample_xy_lens[]; };
layout(set = 3, binding = 1, std430) readonly buffer SamplesTime { float sample_time[]; };
layout(set = 3, binding = 2, std430) buffer Counters {
    uint samples_tested;
    uint samples_hit;
    uint shading_invocations;
    uint fragments;
} counters;
layout(set = 3, binding = 6, rgba32f) uniform image2D accum;

const uint SAMPLE_TILE_SIZE = 64u;
const uint SHADE_BACKGROUND = 0xffffffffu;
const uint SHADE_GROUPS = 8u;  // engine/src/reference: PER_PIXEL_SHADING_GROUPS

// The reference's texture lookup (Texture::sample_bilinear): bilinear at the base level, repeat.
// Visibility first means every sample is shaded at its own point and the S samples of the pixel do
// the filtering; a mip level from the sample footprint would blur against the ground truth.
vec3 texture_bilinear(vec2 uv) {
    ivec2 size = textureSize(albedo_texture, 0);
    vec2 p = uv * vec2(size) - 0.5;
    vec2 p0 = floor(p);
    vec2 f = p - p0;
    ivec2 i0 = ivec2(p0);
    ivec2 t00 = ivec2(mod(vec2(i0), vec2(size))), t11 = ivec2(mod(vec2(i0 + 1), vec2(size)));
    vec3 a = texelFetch(albedo_texture, ivec2(t00.x, t00.y), 0).rgb;
    vec3 b = texelFetch(albedo_texture, ivec2(t11.x, t00.y), 0).rgb;
    vec3 c = texelFetch(albedo_texture, ivec2(t00.x, t11.y), 0).rgb;
    vec3 d = texelFetch(albedo_texture, ivec2(t11.x, t11.y), 0).rgb;
    return mix(mix(a, b, f.x), mix(c, d, f.x), f.y);
}

// The sample's ray and the triangle at its time.
struct SampleHit {
    vec3 a, b, c;  // camera space at t
    vec3 ro, rd;
    float t;
};

SampleHit sample_at(uint prim, uint tile_index, uvec2 pix) {
    SampleHit h;
    vec4 xl = sample_xy_lens[tile_index];
#ifdef NO_DEFOCUS
    xl.zw = vec2(0.0);
#endif
    primary_ray(vec2(pix) + xl.xy, xl.zw, h.ro, h.rd);
    vec3 p_open[3], p_close[3];
    for (uint k = 0u; k < 3u; k++) {
        uint at = 18u * prim + 3u * k;
        p_open[k] = vec3(triangles[at], triangles[at + 1u], triangles[at + 2u]);
        p_close[k] = vec3(triangles[at + 9u], triangles[at + 10u], triangles[at + 11u]);
    }
#ifdef NO_MOTION
    h.t = 0.5;
#else
    h.t = sample_time[tile_index];
#endif
    h.a = mix(p_open[0], p_close[0], h.t);
    h.b = mix(p_open[1], p_close[1], h.t);
    h.c = mix(p_open[2], p_close[2], h.t);
    return h;
}

// Which side of the triangle the ray sees (the group key's low bit).
uint side_of(SampleHit h) {
    return dot(cross(h.b - h.a, h.c - h.a), h.rd) > 0.0 ? 1u : 0u;
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
    ObjectView o = object_views[pc.object];
    Material m = materials[pc.object];
    Vertex tv[3];
    for (uint k = 0u; k < 3u; k++) tv[k] = vertices[indices[3u * prim + k]];
    vec3 geometric = cross(h.b - h.a, h.c - h.a);
    vec3 n = vec3(0.0);
    for (int k = 0; k < 3; k++) {
        vec3 nk = vec3(tv[k].normal[0], tv[k].normal[1], tv[k].normal[2]);
        n += w[k] * mix(mat3(o.normal_matrix[0]) * nk, mat3(o.normal_matrix[1]) * nk, h.t);
    }
    if (dot(n, n) > 0.0) n = normalize(n);
    else if (dot(geometric, geometric) > 0.0) n = normalize(geometric);
    else n = -h.rd;
    if (dot(geometric, h.rd) > 0.0) n = -n;
    vec3 position = w.x * h.a + w.y * h.b + w.z * h.c;
    vec3 albedo = m.albedo_specular.rgb;
    if (m.params.y > 0.5) {
        vec2 uv = w.x * vec2(tv[0].uv[0], tv[0].uv[1]) + w.y * vec2(tv[1].uv[0], tv[1].uv[1])
                + w.z * vec2(tv[2].uv[0], tv[2].uv[1]);
        albedo *= texture_bilinear(uv);
    }
    return shade(position, n, -h.rd, albedo, m.albedo_specular.w, m.params.x, h.t);
}

void main() {
    uvec2 pix = gl_GlobalInvocationID.xy;
    if (any(greaterThanEqual(pix, uvec2(view.viewport.xy)))) return;
    float inv_spp = 1.0 / float(pc.spp);
    if (pc.object == SHADE_BACKGROUND) {
        uint empty = 0u;
        for (uint i = 0u; i < pc.per_pass; i++) {
            if (visibility[visibility_index(pix, i, pc.per_pass)] == 0UL) empty++;
        }
        if (empty > 0u) {
            vec4 add = vec4(world.background.rgb, 1.0) * (float(empty) * inv_spp);
            imageStore(accum, ivec2(pix), imageLoad(accum, ivec2(pix)) + add);
        }
        return;
    }
    uint base = ((pix.y % SAMPLE_TILE_SIZE) * SAMPLE_TILE_SIZE + pix.x % SAMPLE_TILE_SIZE) * pc.spp
              + pc.pass_index * pc.per_pass;
    vec3 sum = vec3(0.0);
    uint count = 0u, shaded = 0u;
#ifdef PER_SAMPLE
    for (uint i = 0u; i < pc.per_pass; i++) {
        uint64_t v = visibility[visibility_index(pix, i, pc.per_pass)];
        uint payload = visibility_payload(v);
        if (v == 0UL || (payload >> PAYLOAD_TRIANGLE_BITS) != pc.object) continue;
        uint prim = payload & PAYLOAD_TRIANGLE_MASK;
        sum += shade_hit(prim, sample_at(prim, base + i, pix));
        count++;
        shaded++;
    }
#else
    // Two phases, so that SIMD lanes (llvmpipe runs 8 pixels in lock-step) shade together: first the
    // pixel's groups — (triangle, side), the first sample of each, how many samples it stands for —
    // then one shading per group. Samples beyond SHADE_GROUPS groups are shaded on their own.
    uint group_key[SHADE_GROUPS];
    uint group_sample[SHADE_GROUPS];
    uint group_count[SHADE_GROUPS];
    uint groups = 0u;
    for (uint i = 0u; i < pc.per_pass; i++) {
        uint64_t v = visibility[visibility_index(pix, i, pc.per_pass)];
        uint payload = visibility_payload(v);
        if (v == 0UL || (payload >> PAYLOAD_TRIANGLE_BITS) != pc.object) continue;
        uint prim = payload & PAYLOAD_TRIANGLE_MASK;
        uint key = (prim << 1) | side_of(sample_at(prim, base + i, pix));
        count++;
        bool found = false;
        for (uint g = 0u; g < groups; g++) {
            if (group_key[g] == key) {
                group_count[g]++;
                found = true;
                break;
            }
        }
        if (found) continue;
        if (groups < SHADE_GROUPS) {
            group_key[groups] = key;
            group_sample[groups] = i;
            group_count[groups] = 1u;
            groups++;
        } else {
            sum += shade_hit(prim, sample_at(prim, base + i, pix));
            shaded++;
        }
    }
    for (uint g = 0u; g < groups; g++) {
        uint prim = group_key[g] >> 1;
        sum += float(group_count[g]) * shade_hit(prim, sample_at(prim, base + group_sample[g], pix));
        shaded++;
    }
#endif
    if (count > 0u) {
        vec4 add = vec4(sum, float(count)) * inv_spp;
        imageStore(accum, ivec2(pix), imageLoad(accum, ivec2(pix)) + add);
    }
#ifdef INSTRUMENTED
    if (shaded > 0u) atomicAdd(counters.shading_invocations, shaded);
#endif
}
