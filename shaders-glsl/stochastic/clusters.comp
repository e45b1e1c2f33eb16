#version 460
// Cluster bounds (engine/src/techniques/stochastic.rs, `Clusters`; CPU mirror bounds::cluster): once
// per frame, per cluster of `cluster_size` triangles consecutive in the object's cluster order (a
// Morton order of their centroids, so neighbours) and key segment of its motion:
//  * the union of its triangles' bounding-box bounds over the segment (compute_bound(BOUND_BBOX),
//    exactly the per-triangle `bbox` bound, so the union is conservative wherever each is), which
//    cluster.vert rasterizes once for the whole cluster;
//  * the lens-centre (pinhole) pixel box of its vertices over the segment and the range of their
//    circle of confusion phi(z): seen through lens point L, every point of the cluster lands in that
//    box moved by phi * L for some phi in the range, so stochastic.frag (CLUSTER_BOUNDS) skips the
//    cluster's triangles for every sample outside it. A cluster with a vertex at or behind the near
//    plane (unbounded projection) has no such box (w = 1: every sample is tested).
// A dense, strongly blurred mesh has many triangles per blur disc: one bound per cluster instead of
// one per triangle cuts the fragments by about the cluster size.
//   NO_MOTION: the triangles at mid-shutter (local time t0 = t1 of the segment holding it).
// A one-sided object's triangles that face away from every lens point over the segment are left out
// of both boxes, as culled ones are (common/back_facing.glsl).
#include "stochastic/bounds.glsl"
#include "stochastic/camera_triangles.glsl"
#include "stochastic/bound_vertices.glsl"
#include "common/back_facing.glsl"

layout(local_size_x = 64) in;

// Per (segment, cluster): screen box (x0, y0, x1, y1) in pixels, undilated (empty: x0 > x1); pinhole
// box (x0, y0, x1, y1) in pixels; (phi_min, phi_max, unbounded 0/1, unused).
layout(set = 2, binding = 3, std430) writeonly buffer Clusters { vec4 clusters[]; };
// The triangles in cluster order (bounds::cluster_order): cluster c is entries [c n, c n + n).
layout(set = 2, binding = 4, std430) readonly buffer ClusterTriangles { uint cluster_triangles[]; };

layout(push_constant) uniform Push {
    uint triangle_count;
    uint cluster_size;
    uint segment_count;  // the object's motion key segments
    uint segment;        // the segment bounded (NO_MOTION: the one holding mid-shutter)
    float t0;            // local times of the segment bounded
    float t1;
    uint one_sided;      // 1: triangles facing away from every lens point over [t0, t1] are left out
} pc;

void main() {
    uint c = gl_GlobalInvocationID.x;
    uint clusters_n = (pc.triangle_count + pc.cluster_size - 1u) / pc.cluster_size;
    if (c >= clusters_n) return;
    const float INF = uintBitsToFloat(0x7f800000u);
    vec2 lo = vec2(INF), hi = vec2(-INF);
    vec2 pin_lo = vec2(INF), pin_hi = vec2(-INF);
    float z_lo = INF, z_hi = -INF;
    bool viewport = false;
    uint end = min(c * pc.cluster_size + pc.cluster_size, pc.triangle_count);
    for (uint k = c * pc.cluster_size; k < end; k++) {
        uint t = cluster_triangles[k];
        vec3 open[3], close[3];
        load_triangle(t, pc.segment, pc.segment_count + 1u, open, close);
        vec3 v[6] = bound_vertices(open, close, pc.t0, pc.t1);
        vec2 pts[BOUND_MAX_POINTS];
        int piece_len[BOUND_MAX_PIECES];
        int pieces = compute_bound(BOUND_BBOX, v, pts, piece_len);
        if (pieces == 0) continue;  // culled: no sample can hit it
        // One-sided and facing away throughout: no sample hits its front (stochastic.geom's rule).
        if (pc.one_sided != 0u
            && back_facing_segment(bound_aperture_(), vec3[3](v[0], v[1], v[2]), vec3[3](v[3], v[4], v[5]))) continue;
        viewport = viewport || pieces < 0;
        int n = 0;
        for (int k = 0; k < pieces; k++) n += piece_len[k];
        for (int i = 0; i < n; i++) {
            lo = min(lo, pts[i]);
            hi = max(hi, pts[i]);
        }
        for (int i = 0; i < 6; i++) {
            float z = -v[i].z;
            z_lo = min(z_lo, z);
            z_hi = max(z_hi, z);
            // Intrinsics::project at the lens centre.
            vec2 p = vec2(0.5 * view.viewport.x + view.viewport.z * (v[i].x / z),
                          0.5 * view.viewport.y - view.viewport.z * (v[i].y / z));
            pin_lo = min(pin_lo, p);
            pin_hi = max(pin_hi, p);
        }
    }
    if (viewport) {
        lo = vec2(0.0);
        hi = view.viewport.xy;
    }
    // phi(z) = A s (1/F - 1/z) grows with z: its range over [z_lo, z_hi].
    float A = view.lens.x, F = view.lens.y, sc = view.viewport.z;
    float phi_lo = A * sc * (1.0 / F - 1.0 / z_lo), phi_hi = A * sc * (1.0 / F - 1.0 / z_hi);
    bool unbounded = !(z_lo > view.lens.z) || !all(lessThan(abs(vec4(pin_lo, pin_hi)), vec4(1e30)));
    uint at = 3u * (pc.segment * clusters_n + c);
    clusters[at] = vec4(lo, hi);
    clusters[at + 1u] = vec4(pin_lo, pin_hi);
    clusters[at + 2u] = vec4(phi_lo, phi_hi, unbounded ? 1.0 : 0.0, 0.0);
}
