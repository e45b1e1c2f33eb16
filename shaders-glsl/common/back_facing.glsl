// Conservative back-face culling over the lens and a linear motion: the GLSL mirror of
// geometry::back_facing_segment (engine/src/geometry.rs, which derives it), operation for operation.
// Does every camera ray from any point of a lens of radius r (centred on the camera-space origin, in
// the plane z = 0) meet the triangle from its back at every time of its motion from p to q? The
// Bernstein lower bound of n(s)·a(s) minus r times the upper bound of |n(s).xy|, by the margin.
#ifndef SHUTTER_BACK_FACING_GLSL
#define SHUTTER_BACK_FACING_GLSL

// geometry::BACK_FACING_MARGIN.
const float BACK_FACING_MARGIN = 1e-4;

bool back_facing_segment(float r, vec3 p[3], vec3 q[3]) {
    vec3 e1p = p[1] - p[0], e2p = p[2] - p[0];
    vec3 e1q = q[1] - q[0], e2q = q[2] - q[0];
    vec3 n0 = cross(e1p, e2p);
    vec3 n1 = 0.5 * (cross(e1p, e2q) + cross(e1q, e2p));
    vec3 n2 = cross(e1q, e2q);
    vec3 a0 = p[0], a1 = q[0];
    float c0 = dot(n0, a0), c1 = (2.0 * dot(n1, a0) + dot(n0, a1)) / 3.0;
    float c2 = (dot(n2, a0) + 2.0 * dot(n1, a1)) / 3.0, c3 = dot(n2, a1);
    float lowest = min(min(c0, c1), min(c2, c3));
    float lens = r * max(max(length(n0.xy), length(n1.xy)), length(n2.xy));
    float scale = max(max(length(n0), length(n1)), length(n2)) * (max(length(a0), length(a1)) + r);
    // NaN is not > 0: kept.
    return lowest - lens - BACK_FACING_MARGIN * scale > 0.0;
}

#endif
