#version 460
// Stochastic rasterization, geometry stage (McGuire et al. 2010; Toth & Linder 2008): replaces each
// triangle by a conservative screen-space bound of everywhere it can land over the lens and shutter
// (stochastic/bounds.glsl, mirrored by engine/src/mirror/bounds), dilated by one pixel box so the rasterizer
// generates a fragment for every pixel whose square touches the bound and covers all of its samples
// (emit.glsl). Only positions and the primitive ID leave this stage: the fragment stage reads the
// triangle itself from the geometry buffers by ID (thesis §9.6: keep the GS output small).
// Effect permutations (engine/src/plan.rs): NO_MOTION bounds the triangle at mid-shutter only,
// NO_DEFOCUS bounds it through the lens centre only (bound_aperture_ = 0).
// A one-sided object's triangle (pc.one_sided) that faces away from every lens point over the draw's
// time interval gets no bound (common/back_facing.glsl): stochastic.frag would drop all its hits.
#include "stochastic/bounds.glsl"
#include "stochastic/visibility_push.glsl"
#include "common/back_facing.glsl"

layout(triangles) in;
layout(triangle_strip, max_vertices = 52) out;  // BOUND_MAX_POINTS + 4 (box dilation adds <= 4)

layout(location = 0) in vec3 v_open[];
layout(location = 1) in vec3 v_close[];

#ifdef BOUND_DEBUG
// Undilated bound of every triangle, for the GLSL-vs-CPU test: per primitive 8 + 2 * BOUND_MAX_POINTS
// floats: [0] piece count (as float), [1..5) piece lengths, [8..) points.
layout(set = 3, binding = 3, std430) writeonly buffer BoundDebug { float bound_debug[]; };
#endif

void emit_ndc(vec2 ndc) {
    gl_Position = vec4(ndc, 0.5, 1.0);
    gl_PrimitiveID = gl_PrimitiveIDIn;
    EmitVertex();
}

void end_strip() {
    EndPrimitive();
}

#include "stochastic/emit.glsl"

void main() {
    vec3 v[6] = bound_vertices(vec3[3](v_open[0], v_open[1], v_open[2]),
                               vec3[3](v_close[0], v_close[1], v_close[2]), pc.t0, pc.t1);
    vec2 pts[BOUND_MAX_POINTS];
    int piece_len[BOUND_MAX_PIECES];
    int pieces = compute_bound(pc.bound, v, pts, piece_len);
#ifdef BOUND_DEBUG
    uint base = uint(gl_PrimitiveIDIn) * uint(8 + 2 * BOUND_MAX_POINTS);
    bound_debug[base] = float(pieces);
    for (int k = 0; k < BOUND_MAX_PIECES; k++) bound_debug[base + 1 + k] = float(k < pieces ? piece_len[k] : 0);
    int total = 0;
    for (int k = 0; k < pieces; k++) total += piece_len[k];
    for (int i = 0; i < total; i++) {
        bound_debug[base + 8 + 2 * i] = pts[i].x;
        bound_debug[base + 9 + 2 * i] = pts[i].y;
    }
#endif
    if (pc.one_sided != 0u && back_facing_segment(bound_aperture_(), vec3[3](v[0], v[1], v[2]),
                                                  vec3[3](v[3], v[4], v[5]))) return;
    emit_bound(pieces, pts, piece_len);
}
