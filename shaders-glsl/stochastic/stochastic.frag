#version 460
// Stochastic rasterization, coverage stage ("visibility first"): for every sample of this draw in the
// pixel whose time lies in the draw's motion key segment, the 5D inside test of its (x, y, u, v, t)
// against the moving, defocused triangle (linear within the segment); each hit
// goes into the visibility buffer (stochastic/visibility.glsl) with its own view depth by one 64-bit
// atomicMax, so occlusion is resolved per sample, exactly, and nothing is shaded here: shade.comp
// shades the surviving hits afterwards. The pass has no attachments and no depth test; a pixel that
// several pieces of a bound (or a pixel split by a strip diagonal) cover is tested more than once, which
// the max makes harmless.
//   INSTRUMENTED: atomic counters of fragments, samples tested and samples hit.
//   NO_MOTION:  defocus-only objects (engine/src/plan.rs): the triangle at mid-shutter, no time
//               interpolation.
//   NO_DEFOCUS: motion-only objects: every sample's ray from the lens centre, no lens sampling.
//   COMPUTE_HULL: behind the compute-expanded hull (hull.vert) rather than the geometry shader.
// llvmpipe runs this for every pixel a bound touches and masks SIMD lanes rather than branching, so
// the work here is only what a miss must pay anyway: load the triangle, test the samples.
#include "common/frame.glsl"
#include "stochastic/inside.glsl"
#include "stochastic/push.glsl"
#include "stochastic/visibility.glsl"
#include "stochastic/camera_triangles.glsl"

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

#ifdef COMPUTE_HULL
// The compute-expanded hull (expand.comp, hull.vert) passes the triangle's index instead of a primitive ID.
layout(location = 0) flat in uint v_triangle;
#endif

const uint SAMPLE_TILE_SIZE = 64u;

void main() {
#ifdef COMPUTE_HULL
    // expand.comp numbers its bounds triangle × segment.
    uint prim = v_triangle / pc.segment_count;
    uint seg = v_triangle % pc.segment_count;
#else
    uint prim = uint(gl_PrimitiveID);
    uint seg = pc.segment;
#endif
    vec3 p_open[3], p_close[3];
    load_triangle(prim, seg, pc.segment_count + 1u, p_open, p_close);
#ifdef NO_MOTION
    for (uint k = 0u; k < 3u; k++) p_open[k] = shutter_lerp(p_open[k], p_close[k], pc.t0);
#else
    // The segment's samples: times in [t_a, t_b) (the first segment from -inf, the last to +inf).
    vec4 seg_time = object_views[pc.segment_first + seg].time;
    const float INF = uintBitsToFloat(0x7f800000u);
    float t_a = seg == 0u ? -INF : seg_time.x;
    float t_b = seg + 1u == pc.segment_count ? INF : seg_time.y;
#endif
    uvec2 pix = uvec2(gl_FragCoord.xy);
    uint base = ((pix.y % SAMPLE_TILE_SIZE) * SAMPLE_TILE_SIZE + pix.x % SAMPLE_TILE_SIZE) * pc.spp
              + pc.pass_index * pc.per_pass;
    uint hits = 0u;
    uint end = pc.sample_first + pc.sample_count;
    for (uint i = pc.sample_first; i < end; i++) {
        vec4 xl = sample_xy_lens[base + i];
#ifdef NO_DEFOCUS
        xl.zw = vec2(0.0);
#endif
        vec3 ro, rd;
        primary_ray(vec2(pix) + xl.xy, xl.zw, ro, rd);
#ifdef NO_MOTION
        vec3 a = p_open[0], b = p_open[1], c = p_open[2];
        bool in_segment = true;
#else
        float t = sample_time[base + i];
        bool in_segment = t >= t_a && t < t_b;
        float s = min((t - seg_time.x) * seg_time.z, 1.0);  // segment_time (common/frame.glsl)
        vec3 a = shutter_lerp(p_open[0], p_close[0], s);
        vec3 b = shutter_lerp(p_open[1], p_close[1], s);
        vec3 c = shutter_lerp(p_open[2], p_close[2], s);
#endif
        float z;
        vec3 w;
        bool back;
        if (sample_hit(a, b, c, ro, rd, z, w, back) && in_segment) {
            atomicMax(visibility[visibility_index(pix, i, pc.per_pass)], visibility_pack(z, pc.triangle_base + prim, back));
            hits++;
        }
    }
#ifdef INSTRUMENTED
    atomicAdd(counters.fragments, 1u);
    atomicAdd(counters.samples_tested, pc.sample_count);
    atomicAdd(counters.samples_hit, hits);
#endif
}
