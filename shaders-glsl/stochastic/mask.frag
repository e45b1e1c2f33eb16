#version 460
// Stochastic rasterization, mask coverage (`coverage=mask`, the path McGuire et al. 2010 publish): the
// pass renders into a multisampled target of M samples per pixel, M = this pass' samples, hardware slot
// k holding pass sample k. The fragment stage runs the same 5D inside test as the visibility coverage
// (stochastic/coverage_draw.glsl) and reports its hits to the hardware: gl_SampleMask says which
// samples the triangle covers, gl_FragDepth how far away it is, and the hardware's per-sample depth
// test keeps the nearest. The colour attachment (R32_UINT) keeps the hit's payload, the visibility
// buffer's (triangle << 1 | back); mask_resolve.comp turns target and depth into the visibility
// buffer, and the shading stages run on it unchanged. No 64-bit atomics anywhere.
//   MASK_PER_SAMPLE: sample-rate shading, one invocation per covered slot (gl_SampleID) testing its
//       own sample and writing its own depth: the same nearest hit per sample as the visibility buffer.
//   otherwise (`coverage=mask-per-fragment`): one invocation per pixel tests all of the draw's samples
//       (the published loop), writes the mask and ONE depth for all of them — the nearest hit's. A
//       sample another triangle covers between that depth and its own true depth is ordered wrongly:
//       the path's known approximation, measured in docs/HARDWARE.md.
//   COMPUTE_HULL, NO_MOTION, NO_DEFOCUS, INSTRUMENTED: as in stochastic.frag.
// Depth: the view depth times 2^-32, a power of two, so the D32_SFLOAT attachment stores the view
// depth's own bits (scaled) and orders hits as the visibility buffer's float comparison does; cleared
// to 1.0 (a view depth of 2^32: nothing). Equal depths go to the later draw (LESS_OR_EQUAL): objects
// and their triangles are drawn in the frame's triangle order, so the later is the larger payload, the
// one the visibility buffer's atomicMax keeps — the same hit, tie for tie.
#include "common/frame.glsl"
#include "stochastic/inside.glsl"
#include "stochastic/visibility_push.glsl"
#include "stochastic/camera_triangles.glsl"
#include "common/coverage.glsl"
#include "common/texture_sample.glsl"
#include "stochastic/coverage_draw.glsl"

#ifdef COMPUTE_HULL
layout(location = 0) flat in uint v_triangle;
#endif

layout(location = 0) out uint o_payload;

// engine/src/techniques/stochastic/mask.rs: MASK_DEPTH_SCALE.
const float MASK_DEPTH_SCALE = 2.3283064365386963e-10;  // 2^-32

void main() {
#ifdef COMPUTE_HULL
    uint prim = v_triangle / pc.segment_count;
    uint seg = v_triangle % pc.segment_count;
#else
    uint prim = uint(gl_PrimitiveID);
    uint seg = pc.segment;
#endif
    uvec2 pix = uvec2(gl_FragCoord.xy);
    uint base = tile_base(pix);
    uint first = pc.sample_first, end = pc.sample_first + pc.sample_count;
#ifdef MASK_PER_SAMPLE
    // This invocation's slot only (outside the draw's run: nothing to test).
    uint slot = uint(gl_SampleID);
    first = max(first, slot);
    end = min(end, slot + 1u);
#endif
    DrawnTriangle d = drawn_triangle(prim, seg);
    Coverage coverage = triangle_coverage(pix, pc.triangle_base + prim);
    const float INF = uintBitsToFloat(0x7f800000u);
    float nearest = INF;
    bool nearest_back = false;
    uint mask = 0u, tested = 0u;
    for (uint i = first; i < end; i++) {
        float z;
        vec3 w;
        bool back;
        if (drawn_sample_hit(d, pix, base, i, z, w, back) && sample_covered(coverage, i, prim, w)) {
            mask |= 1u << i;
            if (z < nearest) {
                nearest = z;
                nearest_back = back;
            }
        }
        tested++;
    }
#ifdef INSTRUMENTED
    atomicAdd(counters.fragments, 1u);
    atomicAdd(counters.samples_tested, tested);
    atomicAdd(counters.samples_hit, uint(bitCount(mask)));
#endif
    if (mask == 0u) discard;
    gl_SampleMask[0] = int(mask);
    gl_FragDepth = nearest * MASK_DEPTH_SCALE;
    o_payload = ((pc.triangle_base + prim) << 1) | (nearest_back ? 1u : 0u);
}
