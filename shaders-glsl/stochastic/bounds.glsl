// TEMPORARY STUB (replaced by the real mirror of engine/src/bounds): bbox for every kind.
#ifndef SHUTTER_BOUNDS_GLSL
#define SHUTTER_BOUNDS_GLSL
#include "common/frame.glsl"
#define BOUND_MAX_POINTS 48
#define BOUND_MAX_PIECES 4
int compute_bound(uint kind, vec3 v[6], out vec2 pts[BOUND_MAX_POINTS], out int piece_len[BOUND_MAX_PIECES]) {
    for (int i = 0; i < BOUND_MAX_POINTS; i++) pts[i] = vec2(0.0);
    for (int i = 0; i < BOUND_MAX_PIECES; i++) piece_len[i] = 0;
    float W = frame.viewport.x, H = frame.viewport.y, s = frame.viewport.z;
    float A = frame.lens.x, F = frame.lens.y, nz = frame.lens.z, fz = frame.lens.w;
    bool all_near = true, all_far = true, any_near = false;
    for (int i = 0; i < 6; i++) {
        float z = -v[i].z;
        all_near = all_near && z < nz; all_far = all_far && z > fz; any_near = any_near || z <= nz;
    }
    if (all_near || all_far) return 0;
    if (any_near) return -1;
    vec2 lo = vec2(1e30), hi = vec2(-1e30);
    for (int i = 0; i < 6; i++) {
        float z = -v[i].z;
        vec2 c = vec2(0.5 * W + s * v[i].x / z, 0.5 * H - s * v[i].y / z);
        float r = abs(A * s * (1.0 / F - 1.0 / z)) * 1.0823922;
        lo = min(lo, c - r); hi = max(hi, c + r);
    }
    pts[0] = lo; pts[1] = vec2(hi.x, lo.y); pts[2] = hi; pts[3] = vec2(lo.x, hi.y);
    piece_len[0] = 4;
    return 1;
}
#endif
