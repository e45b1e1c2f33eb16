// The vertices a triangle's bound covers over a draw's time, shared by the per-triangle bounds
// (stochastic.geom, expand.comp, through emit.glsl) and the cluster bounds (clusters.comp).
#ifndef SHUTTER_BOUND_VERTICES_GLSL
#define SHUTTER_BOUND_VERTICES_GLSL
#include "stochastic/inside.glsl"

// The end vertices the bound covers: the triangle at local times t0 (0..2) and t1 (3..5) of one motion
// key segment (open/close: its keys) — the whole segment is (0, 1), a sub-interval bounds one run of
// time-ordered samples (interval bounds; linear motion within the segment keeps the triangle between
// its positions at t0 and t1); in the defocus-only permutation (NO_MOTION) the triangle at mid-shutter
// (local time t0 = t1) at both ends (the fragment stage tests it there).
vec3[6] bound_vertices(vec3 open[3], vec3 close[3], float t0, float t1) {
#ifdef NO_MOTION
    // t0 = t1: mid-shutter's time in its segment.
    vec3 m0 = shutter_lerp(open[0], close[0], t0), m1 = shutter_lerp(open[1], close[1], t0);
    vec3 m2 = shutter_lerp(open[2], close[2], t0);
    return vec3[6](m0, m1, m2, m0, m1, m2);
#else
    if (t0 == 0.0 && t1 == 1.0) return vec3[6](open[0], open[1], open[2], close[0], close[1], close[2]);
    return vec3[6](shutter_lerp(open[0], close[0], t0), shutter_lerp(open[1], close[1], t0),
                   shutter_lerp(open[2], close[2], t0), shutter_lerp(open[0], close[0], t1),
                   shutter_lerp(open[1], close[1], t1), shutter_lerp(open[2], close[2], t1));
#endif
}

#endif
