#version 460
// Stochastic rasterization, coverage stage ("visibility first"): for every sample of this draw in the
// pixel whose time lies in the draw's motion key segment, the 5D inside test of its (x, y, u, v, t)
// against the moving, defocused triangle (linear within the segment); each hit
// goes into the visibility buffer (stochastic/visibility.glsl) with its own view depth by one 64-bit
// atomicMax, so occlusion is resolved per sample, exactly, and nothing is shaded here: the shading
// stages (shade_*.comp) shade the surviving hits afterwards. The pass has no attachments and no depth
// test; a pixel that several pieces of a bound (or a pixel split by a strip diagonal) cover is tested
// more than once, which the max makes harmless.
//   INSTRUMENTED: atomic counters of fragments, samples tested and samples hit.
//   NO_MOTION:  defocus-only objects (engine/src/plan.rs): the triangle at mid-shutter, no time
//               interpolation.
//   NO_DEFOCUS: motion-only objects: every sample's ray from the lens centre, no lens sampling.
//   COMPUTE_HULL: behind the compute-expanded hull (hull.vert) rather than the geometry shader.
// A partly covering object (pc.alpha < 1) keeps a hit only on the samples it covers (stochastic
// transparency, docs/TRANSPARENCY.md); "samples hit" then counts covered hits. A one-sided object
// (pc.one_sided) has no hits on its back: the reference's camera rays pass through it there.
//   TINT_PASS: after the coverage pass, the tinted objects again (behind a one-piece bound, so every
//              sample is tested once per triangle): each sample the triangle hits but does NOT cover,
//              strictly in front of the hit the visibility buffer holds for it, gets the tint added to
//              its entry of the tint buffer as −log2 T in fixed point (transparency::tint_log) — an
//              integer sum, so the product of the tints in front of a sample's visible surface comes
//              out the same whatever order the atomics run in. The shading (TINTS) multiplies it in.
// llvmpipe runs this for every pixel a bound touches and masks SIMD lanes rather than branching, so
// the work here is only what a miss must pay anyway: load the triangle, test the samples.
#include "common/frame.glsl"
#include "stochastic/inside.glsl"
#include "stochastic/visibility_push.glsl"
#include "stochastic/visibility.glsl"
#include "stochastic/camera_triangles.glsl"
#include "common/coverage.glsl"
#include "common/texture_sample.glsl"
#include "stochastic/coverage_draw.glsl"

#ifdef COMPUTE_HULL
// The compute-expanded hull (expand.comp, hull.vert) passes the triangle's index instead of a primitive ID.
layout(location = 0) flat in uint v_triangle;
#endif
#ifdef CLUSTER_BOUNDS
// Cluster bounds (clusters.comp, cluster.vert): the cluster of primitive p (two per cluster) is p / 2.
layout(set = 2, binding = 3, std430) readonly buffer Clusters { vec4 clusters[]; };
layout(set = 2, binding = 4, std430) readonly buffer ClusterTriangles { uint cluster_triangles[]; };

// Can the sample at pixel position q through lens point `lens` (unit aperture) see the cluster whose
// lens-centre pixel box is pin (x0, y0, x1, y1) and circle-of-confusion range phi (min, max, unbounded)?
// Through the lens a point lands at its lens-centre position moved by phi(z) * (lens.x, -lens.y) px
// (Intrinsics::project), phi in the range: the box so moved, padded for rounding (bounds::cluster).
bool sample_sees_cluster(vec2 q, vec2 lens, vec4 pin, vec4 phi) {
    vec2 l = vec2(lens.x, -lens.y);
    vec2 a = phi.x * l, b = phi.y * l;
    vec2 lo = pin.xy + min(a, b), hi = pin.zw + max(a, b);
    vec2 pad = 0.01 + 1e-4 * max(abs(lo), abs(hi));
    return phi.z > 0.5 || (all(greaterThanEqual(q, lo - pad)) && all(lessThanEqual(q, hi + pad)));
}
#endif

#ifdef TINT_PASS
layout(set = 3, binding = 7, std430) buffer TintLog { uint tint_log[]; };
#endif

// A hit of sample i of this pass at view depth z on triangle `tri` (the frame's numbering), seen from
// the back or not, that the triangle's coverage does or does not keep: into the visibility buffer
// (coverage pass) or, uncovered and in front of the sample's visible hit, into the tint buffer (tint
// pass). Whether it counted.
bool keep_hit(uvec2 pix, uint i, float z, uint tri, bool back, bool covered) {
    uint at = visibility_index(pix, i, pc.per_pass);
#ifdef TINT_PASS
    if (covered) return false;
    uint64_t v = visibility[at];
    // No hit (0): the background, behind everything.
    if (v != 0UL && !(z < uintBitsToFloat(~uint(v >> 32)))) return false;
    atomicAdd(tint_log[3u * at], pc.tint_log_r);
    atomicAdd(tint_log[3u * at + 1u], pc.tint_log_g);
    atomicAdd(tint_log[3u * at + 2u], pc.tint_log_b);
#else
    if (!covered) return false;
    atomicMax(visibility[at], visibility_pack(z, tri, back));
#endif
    return true;
}

void main() {
#if defined(CLUSTER_BOUNDS)
    uint seg = pc.segment;
    uint clusters_n = (pc.triangle_count + pc.cluster_size - 1u) / pc.cluster_size;
    uint cluster = uint(gl_PrimitiveID) / 2u;
    uint cluster_at = 3u * (seg * clusters_n + cluster);
    vec4 pin = clusters[cluster_at + 1u], phi = clusters[cluster_at + 2u];
    uint first = cluster * pc.cluster_size;
    uint last = min(first + pc.cluster_size, pc.triangle_count);
#elif defined(COMPUTE_HULL)
    // expand.comp numbers its bounds triangle × segment.
    uint prim = v_triangle / pc.segment_count;
    uint seg = v_triangle % pc.segment_count;
#else
    uint prim = uint(gl_PrimitiveID);
    uint seg = pc.segment;
#endif
#ifdef CLUSTER_BOUNDS
    vec3 p_open[3], p_close[3];
#ifndef NO_MOTION
    // The segment's samples: times in [t_a, t_b) (the first segment from -inf, the last to +inf).
    vec4 seg_time = object_views[pc.segment_first + seg].time;
    const float INF = uintBitsToFloat(0x7f800000u);
    float t_a = seg == 0u ? -INF : seg_time.x;
    float t_b = seg + 1u == pc.segment_count ? INF : seg_time.y;
#endif
#endif
    uvec2 pix = uvec2(gl_FragCoord.xy);
    uint base = tile_base(pix);
    uint hits = 0u, tested = 0u;
    uint end = pc.sample_first + pc.sample_count;
#ifndef CLUSTER_BOUNDS
    DrawnTriangle d = drawn_triangle(prim, seg);
    Coverage coverage = triangle_coverage(pix, pc.triangle_base + prim);
    for (uint i = pc.sample_first; i < end; i++) {
        float z;
        vec3 w;
        bool back;
        if (drawn_sample_hit(d, pix, base, i, z, w, back)) {
            bool covered = sample_covered(coverage, i, prim, w);
            if (keep_hit(pix, i, z, pc.triangle_base + prim, back, covered)) hits++;
        }
        tested++;
    }
#else
    // Per 32 samples: first which samples can see the cluster (cheap), then the cluster's triangles
    // for those samples only — llvmpipe runs the lanes of 8 pixels together, so this loop runs as many
    // times as the busiest lane has such samples, not once per sample that any lane has. The nearest
    // hit among the triangles goes in with one atomicMax: the max of the per-triangle packs, the same
    // result as one atomicMax each.
    for (uint chunk = pc.sample_first; chunk < end; chunk += 32u) {
        uint bits = 0u;
        for (uint j = 0u; j < min(32u, end - chunk); j++) {
            uint i = chunk + j;
            vec4 xl = sample_xy_lens[base + i];
#ifdef NO_DEFOCUS
            xl.zw = vec2(0.0);
#endif
#ifdef NO_MOTION
            bool in_segment = true;
#else
            float t = sample_time[base + i];
            bool in_segment = t >= t_a && t < t_b;
#endif
            bits |= in_segment && sample_sees_cluster(vec2(pix) + xl.xy, xl.zw, pin, phi) ? 1u << j : 0u;
        }
        if (bits == 0u) continue;
        for (uint k = first; k < last; k++) {
            uint prim = cluster_triangles[k];
            load_triangle(prim, seg, pc.segment_count + 1u, p_open, p_close);
            Coverage coverage = triangle_coverage(pix, pc.triangle_base + prim);
            uint todo = bits;
            while (todo != 0u) {
                uint i = chunk + uint(findLSB(todo));
                todo &= todo - 1u;
                vec4 xl = sample_xy_lens[base + i];
#ifdef NO_DEFOCUS
                xl.zw = vec2(0.0);
#endif
                vec3 ro, rd;
                primary_ray(vec2(pix) + xl.xy, xl.zw, ro, rd);
#ifdef NO_MOTION
                float s = pc.t0;
#else
                float s = min((sample_time[base + i] - seg_time.x) * seg_time.z, 1.0);
#endif
                vec3 a = shutter_lerp(p_open[0], p_close[0], s);
                vec3 b = shutter_lerp(p_open[1], p_close[1], s);
                vec3 c = shutter_lerp(p_open[2], p_close[2], s);
                float z;
                vec3 w;
                bool back;
                if (sample_hit(a, b, c, ro, rd, z, w, back) && !(back && pc.one_sided != 0u)) {
                    bool covered = sample_covered(coverage, i, prim, w);
                    if (keep_hit(pix, i, z, pc.triangle_base + prim, back, covered)) hits++;
                }
                tested++;
            }
        }
    }
#endif
#ifdef INSTRUMENTED
    atomicAdd(counters.fragments, 1u);
    atomicAdd(counters.samples_tested, tested);
    atomicAdd(counters.samples_hit, hits);
#endif
}
