#version 460
// The compute-expanded hull (a hardware-feature experiment: lavapipe runs compute on every core but its
// geometry stage on one): once per frame and object, each invocation bounds one triangle over one key
// segment of its object's motion exactly as
// stochastic.geom does (compute_bound, emit.glsl's dilation) and appends the strips as a triangle list
// to the object's hull buffer — NDC x, y per vertex, and the source triangle's index per hull triangle
// in a second buffer (8 + 4/3 bytes per vertex) — reserving its vertices with one atomicAdd. A plain draw of that buffer (hull.vert) then feeds the
// same fragment shader (COMPUTE_HULL). Past the buffer's capacity nothing is written but the count
// still grows: the renderer reads it back, grows the buffer and expands again, so no bound is lost.
#include "stochastic/bounds.glsl"
#include "stochastic/camera_triangles.glsl"
#include "common/back_facing.glsl"

layout(local_size_x = 64) in;

// The expanded hull: triangle-list vertices and the source triangle of each.
layout(set = 2, binding = 1, std430) writeonly buffer Hull { vec2 hull[]; };
layout(set = 2, binding = 2, std430) writeonly buffer HullTriangles { uint hull_triangle[]; };
layout(set = 3, binding = 4, std430) buffer HullCounts { uint hull_vertices[]; };

layout(push_constant) uniform Push {
    uint object;          // index into hull_vertices
    uint triangle_count;
    uint bound;           // bound kind id
    uint capacity;        // vertices the hull buffer holds
    float dilate;         // box half-size, pixels (emit.glsl reads pc.dilate)
    uint segment_count;   // the object's motion key segments
    uint segment_begin;   // bounds are made for segments [segment_begin, segment_begin + segments)
    uint segments;        // (NO_MOTION: the one segment holding mid-shutter)
    float t0;             // over local times [t0, t1] of each (NO_MOTION: t0 = t1, mid-shutter's)
    float t1;
    uint one_sided;       // 1: triangles facing away from every lens point over [t0, t1] get no bound
} pc;

// The strips of this invocation's bound, gathered before they are written as triangles.
const int MAX_STRIP_POINTS = BOUND_MAX_POINTS + 4 * BOUND_MAX_PIECES + 4;
vec2 strip_pts[MAX_STRIP_POINTS];
int strip_end[BOUND_MAX_PIECES + 1];
int strip_n = 0, strips = 0;

void emit_ndc(vec2 ndc) {
    if (strip_n < MAX_STRIP_POINTS) strip_pts[strip_n++] = ndc;
}

void end_strip() {
    strip_end[strips++] = strip_n;
}

#include "stochastic/emit.glsl"

void main() {
    uint id = gl_GlobalInvocationID.x;
    if (id >= pc.triangle_count * pc.segments) return;
    // One bound per triangle and key segment.
    uint t = id / pc.segments;
    uint seg = pc.segment_begin + id % pc.segments;
    vec3 open[3], close[3];
    load_triangle(t, seg, pc.segment_count + 1u, open, close);
    vec3 v[6] = bound_vertices(open, close, pc.t0, pc.t1);
    // One-sided: a triangle no sample sees the front of gets no bound (stochastic.geom's rule).
    if (pc.one_sided != 0u
        && back_facing_segment(bound_aperture_(), vec3[3](v[0], v[1], v[2]), vec3[3](v[3], v[4], v[5]))) return;
    vec2 pts[BOUND_MAX_POINTS];
    int piece_len[BOUND_MAX_PIECES];
    int pieces = compute_bound(pc.bound, v, pts, piece_len);
    emit_bound(pieces, pts, piece_len);
    uint n = 0u;
    int begin = 0;
    for (int s = 0; s < strips; s++) {
        n += uint(3 * max(strip_end[s] - begin - 2, 0));
        begin = strip_end[s];
    }
    if (n == 0u) return;
    uint base = atomicAdd(hull_vertices[pc.object], n);
    if (base + n > pc.capacity) return;  // counted, not written: the renderer grows the buffer and reruns
    uint w = base;
    begin = 0;
    for (int s = 0; s < strips; s++) {
        // Strip triangle k is (k, k + 1, k + 2); winding does not matter (nothing is culled).
        for (int k = begin; k + 2 < strip_end[s]; k++) {
            hull_triangle[w / 3u] = t * pc.segment_count + seg;  // stochastic.frag splits it
            for (int j = 0; j < 3; j++) hull[w + uint(j)] = strip_pts[k + j];
            w += 3u;
        }
        begin = strip_end[s];
    }
}
