#version 460
// Stochastic rasterization, fragment stage: for each of this pass' samples of the pixel, the 5D inside
// test of its (x, y, u, v, t) against the moving, defocused triangle; coverage goes out through
// gl_SampleMask and the hit's depth through gl_FragDepth (reversed Z), so occlusion is resolved per
// sample by the ordinary depth test.
//   default:    per-pixel shading (MSAA-like): the covered samples tested in one invocation, the nearest hit is
//               shaded once and its depth is written for every covered sample (the artefact of the
//               ATSS paper's Figure 9: farther covered samples take the nearest one's depth).
//   PER_SAMPLE: sample-rate shading: one invocation per sample (gl_SampleID), each shaded with its own
//               hit, time and lens point and writing its own depth.
//   INSTRUMENTED: atomic counters of samples tested, samples hit, shading invocations, fragments.
//   NO_MOTION:  defocus-only objects (engine/src/plan.rs): the triangle at mid-shutter, no time
//               interpolation, every sample shaded at t = 0.5.
//   NO_DEFOCUS: motion-only objects: every sample's ray from the lens centre, no lens sampling.
//   COMPUTE_HULL: behind the compute-expanded hull (hull.vert) rather than the geometry shader.
// Attributes are interpolated with the sample's barycentrics; textures use analytic derivatives from
// the triangle's plane over one sample's footprint; the view vector points to the sample's lens point.
#include "common/object.glsl"
#include "common/shading.glsl"
#include "stochastic/inside.glsl"
#include "stochastic/push.glsl"

// Camera-space triangles at shutter open and close, 18 floats each (written by triangles.comp).
layout(set = 2, binding = 0, std430) readonly buffer Triangles { float triangles[]; };

// The sample tile (sampling::SampleTile): 64 x 64 pixels x S samples; xy in [0,1) within the pixel,
// lens already mapped to the aperture shape, time already warped by the shutter curve.
layout(set = 3, binding = 0, std430) readonly buffer SamplesXyLens { vec4 sample_xy_lens[]; };
layout(set = 3, binding = 1, std430) readonly buffer SamplesTime { float sample_time[]; };
layout(set = 3, binding = 2, std430) buffer Counters {
    uint samples_tested;
    uint samples_hit;
    uint shading_invocations;
    uint fragments;
} counters;

layout(location = 0) out vec4 out_color;
#ifdef COMPUTE_HULL
// The compute-expanded hull (expand.comp, hull.vert) passes the triangle's index instead of a primitive ID.
layout(location = 0) flat in uint v_triangle;
#endif

const uint SAMPLE_TILE_SIZE = 64u;

// Reversed-Z depth of view depth z (the same value thin_lens_clip produces).
float depth_value(float z) {
    float near_z = view.lens.z, far_z = view.lens.w;
    return clamp(near_z * (far_z - z) / ((far_z - near_z) * z), 0.0, 1.0);
}

void main() {
#ifdef COMPUTE_HULL
    uint prim = v_triangle;
#else
    uint prim = uint(gl_PrimitiveID);
#endif
    vec3 p_open[3], p_close[3];
    for (uint k = 0u; k < 3u; k++) {
        uint at = 18u * prim + 3u * k;
        p_open[k] = vec3(triangles[at], triangles[at + 1u], triangles[at + 2u]);
        p_close[k] = vec3(triangles[at + 9u], triangles[at + 10u], triangles[at + 11u]);
    }
#ifdef NO_MOTION
    for (uint k = 0u; k < 3u; k++) p_open[k] = mix(p_open[k], p_close[k], 0.5);
#endif
    uvec2 pix = uvec2(gl_FragCoord.xy);
    uint base = ((pix.y % SAMPLE_TILE_SIZE) * SAMPLE_TILE_SIZE + pix.x % SAMPLE_TILE_SIZE) * pc.spp
              + pc.pass_index * pc.msaa;

    // `covered`: the samples this fragment owns — one (sample-rate shading) or the pixel's samples inside
    // this primitive of the bound's strip (a pixel split by a strip diagonal gets one fragment per side,
    // each owning its samples). Hits among owned samples go out through gl_SampleMask and are counted
    // once. Per-pixel shading still tests the pixel's other samples too, so that every fragment of a
    // split pixel picks the same nearest hit: the image never depends on how a bound is triangulated.
#ifdef PER_SAMPLE
    uint covered = 1u << uint(gl_SampleID);
    int first = gl_SampleID, last = gl_SampleID + 1;
#else
    uint covered = uint(gl_SampleMaskIn[0]) & ((1u << pc.msaa) - 1u);
    int first = 0, last = int(pc.msaa);
#endif
    uint mask = 0u;
    float best_z = 1.0 / 0.0;
    vec3 best_w = vec3(0.0), best_o = vec3(0.0), best_d = vec3(0.0);
    float best_t = 0.0;
    vec2 best_pixel = vec2(0.0), best_lens = vec2(0.0);
    for (int i = first; i < last; i++) {
        vec4 xl = sample_xy_lens[base + uint(i)];
#ifdef NO_DEFOCUS
        xl.zw = vec2(0.0);
#endif
        vec2 pixel = vec2(pix) + xl.xy;
        vec3 ro, rd;
        primary_ray(pixel, xl.zw, ro, rd);
#ifdef NO_MOTION
        float t = 0.5;
        vec3 a = p_open[0], b = p_open[1], c = p_open[2];
#else
        float t = sample_time[base + uint(i)];
        vec3 a = mix(p_open[0], p_close[0], t);
        vec3 b = mix(p_open[1], p_close[1], t);
        vec3 c = mix(p_open[2], p_close[2], t);
#endif
        float z;
        vec3 w;
        if (sample_hit(a, b, c, ro, rd, z, w)) {
            mask |= covered & (1u << uint(i));
            if (z < best_z) {
                best_z = z;
                best_w = w;
                best_o = ro;
                best_d = rd;
                best_t = t;
                best_pixel = pixel;
                best_lens = xl.zw;
            }
        }
    }
#ifdef INSTRUMENTED
    atomicAdd(counters.fragments, 1u);
    atomicAdd(counters.samples_tested, uint(bitCount(covered)));
    atomicAdd(counters.samples_hit, uint(bitCount(mask)));
#endif
    if (mask == 0u) discard;
#ifdef INSTRUMENTED
    atomicAdd(counters.shading_invocations, 1u);
#endif
    gl_SampleMask[0] = int(mask);
    gl_FragDepth = depth_value(best_z);

    // Shade the chosen hit (the reference's rules: engine/src/reference/mod.rs). The object's
    // transforms and material are read only here, after the discard: llvmpipe runs the fragment stage
    // for every pixel a bound touches and pays loads before the discard for the misses too.
    ObjectView o = object_views[pc.object];
    Material m = materials[pc.object];
    Vertex tv[3];
    for (uint k = 0u; k < 3u; k++) tv[k] = vertices[indices[3u * prim + k]];
    float t = best_t;
#ifdef NO_MOTION
    vec3 a = p_open[0], b = p_open[1], c = p_open[2];
#else
    vec3 a = mix(p_open[0], p_close[0], t);
    vec3 b = mix(p_open[1], p_close[1], t);
    vec3 c = mix(p_open[2], p_close[2], t);
#endif
    vec3 geometric = cross(b - a, c - a);
    vec3 n = vec3(0.0);
    for (int k = 0; k < 3; k++) {
        vec3 nk = vec3(tv[k].normal[0], tv[k].normal[1], tv[k].normal[2]);
        n += best_w[k] * mix(mat3(o.normal_matrix[0]) * nk, mat3(o.normal_matrix[1]) * nk, t);
    }
    if (dot(n, n) > 0.0) n = normalize(n);
    else if (dot(geometric, geometric) > 0.0) n = normalize(geometric);
    else n = -best_d;
    if (dot(geometric, best_d) > 0.0) n = -n;
    vec3 position = best_w.x * a + best_w.y * b + best_w.z * c;
    vec3 albedo = m.albedo_specular.rgb;
    if (m.params.y > 0.5) {
        vec2 uv0 = vec2(tv[0].uv[0], tv[0].uv[1]), uv1 = vec2(tv[1].uv[0], tv[1].uv[1]);
        vec2 uv2 = vec2(tv[2].uv[0], tv[2].uv[1]);
        vec2 uv = best_w.x * uv0 + best_w.y * uv1 + best_w.z * uv2;
        // Analytic footprint: the same lens point and time, rays one sample spacing to the right and down.
        vec3 ro, rdx, rdy;
        bool okx, oky;
        primary_ray(best_pixel + vec2(pc.footprint, 0.0), best_lens, ro, rdx);
        primary_ray(best_pixel + vec2(0.0, pc.footprint), best_lens, ro, rdy);
        vec3 wx = plane_barycentrics(a, b, c, best_o, rdx, okx);
        vec3 wy = plane_barycentrics(a, b, c, best_o, rdy, oky);
        vec2 dx = okx ? wx.x * uv0 + wx.y * uv1 + wx.z * uv2 - uv : vec2(0.0);
        vec2 dy = oky ? wy.x * uv0 + wy.y * uv1 + wy.z * uv2 - uv : vec2(0.0);
        albedo *= textureGrad(albedo_texture, uv, dx, dy).rgb;
    }
    out_color = vec4(shade(position, n, -best_d, albedo, m.albedo_specular.w, m.params.x, t), 1.0);
}
