// The 5D inside test: the GLSL mirror of bounds::sample_hit (engine/src/mirror/bounds/inside.rs), operation for
// operation. Does the thin-lens ray through `pixel` from lens sample `lens` hit triangle (a, b, c)
// (camera space at the sample's time)? Möller–Trumbore, edges inclusive, the hit's depth clamped to the
// vertices' depth range; hits outside [near, far], degenerate triangles and rays in the triangle's plane
// are rejected.
#ifndef SHUTTER_INSIDE_GLSL
#define SHUTTER_INSIDE_GLSL
#include "common/frame.glsl"

const float PARALLEL_EPS = 1e-7;

// MovingTriangle::at's interpolation: exact for a vertex that does not move (mix's (1-t)a + tb is not).
vec3 shutter_lerp(vec3 a, vec3 b, float t) {
    precise vec3 r = a + (b - a) * t;  // not fused: MovingTriangle::at rounds the product
    return r;
}

// glam's f32 Vec3 dot, cross and normalize, operation for operation and never fused into
// multiply-adds (precise), so that the ray and the inside test below are bounds::sample_hit's bit for
// bit: through a telephoto lens one ulp of a ray's direction or of a product is a visible part of a
// pixel (0.001 degrees from 20 km: a fifth), and the built-ins rounded differently from the CPU.
float dot_exact(vec3 a, vec3 b) {
    precise float r = a.x * b.x + a.y * b.y;
    r = r + a.z * b.z;
    return r;
}
vec3 cross_exact(vec3 a, vec3 b) {
    precise vec3 r = vec3(a.y * b.z - b.y * a.z, a.z * b.x - b.z * a.x, a.x * b.y - b.x * a.y);
    return r;
}
float length_exact(vec3 v) {
    precise float r = sqrt(dot_exact(v, v));
    return r;
}
vec3 normalize_exact(vec3 v) {
    precise float inv = 1.0 / length_exact(v);
    precise vec3 r = v * inv;
    return r;
}

// Intrinsics::primary_ray: origin on the lens, direction through the focus-plane point of the pixel.
void primary_ray(vec2 pixel, vec2 lens, out vec3 o, out vec3 d) {
    float W = view.viewport.x, H = view.viewport.y, s = view.viewport.z;
    float A = view.lens.x, F = view.lens.y;
    precise vec2 tan_xy = vec2((pixel.x - 0.5 * W) / s, -(pixel.y - 0.5 * H) / s);
    precise vec3 origin = vec3(A * lens, 0.0);
    precise vec3 focus_point = vec3(tan_xy.x * F, tan_xy.y * F, -F);
    o = origin;
    d = normalize_exact(focus_point - origin);
}

// Barycentrics (w0, w1, w2) of the ray's intersection with the plane of (a, b, c), without range checks
// (for texture footprints). `ok` is false for a degenerate triangle or a ray in its plane.
vec3 plane_barycentrics(vec3 a, vec3 b, vec3 c, vec3 o, vec3 d, out bool ok) {
    vec3 e1 = b - a;
    vec3 e2 = c - a;
    float n_len = length(cross(e1, e2));
    vec3 p = cross(d, e2);
    float det = dot(e1, p);
    ok = n_len > PARALLEL_EPS * length(e1) * length(e2) && abs(det) > PARALLEL_EPS * n_len;
    if (!ok) return vec3(1.0, 0.0, 0.0);
    float inv = 1.0 / det;
    vec3 s = o - a;
    float b1 = dot(s, p) * inv;
    float b2 = dot(d, cross(s, e1)) * inv;
    return vec3(1.0 - b1 - b2, b1, b2);
}

// `back`: the ray sees the triangle's back (det < 0, TriangleHit::back).
bool sample_hit(vec3 a, vec3 b, vec3 c, vec3 o, vec3 d, out float depth_z, out vec3 w, out bool back) {
    depth_z = 0.0;
    w = vec3(0.0);
    back = false;
    precise vec3 e1 = b - a;
    precise vec3 e2 = c - a;
    vec3 n = cross_exact(e1, e2);
    precise float n_len = length_exact(n);
    if (isnan(n_len) || n_len <= PARALLEL_EPS * length_exact(e1) * length_exact(e2)) return false;
    vec3 p = cross_exact(d, e2);
    float det = dot_exact(e1, p);
    if (isnan(det) || abs(det) <= PARALLEL_EPS * n_len) return false;
    back = det < 0.0;
    precise float inv = 1.0 / det;
    precise vec3 s = o - a;
    precise float b1 = dot_exact(s, p) * inv;
    if (!(b1 >= 0.0 && b1 <= 1.0)) return false;
    vec3 q = cross_exact(s, e1);
    precise float b2 = dot_exact(d, q) * inv;
    if (!(b2 >= 0.0 && b1 + b2 <= 1.0)) return false;
    precise vec3 bary = vec3(1.0 - b1 - b2, b1, b2);
    w = bary;
    // Clamped to the vertices' depth range (rounding can leave it; a face exactly on the near plane).
    float z_lo = -max(max(a.z, b.z), c.z), z_hi = -min(min(a.z, b.z), c.z);
    precise float z = -(w.x * a.z + w.y * b.z + w.z * c.z);
    depth_z = min(max(z, z_lo), z_hi);
    return depth_z >= view.lens.z && depth_z <= view.lens.w;
}

bool sample_hit(vec3 a, vec3 b, vec3 c, vec3 o, vec3 d, out float depth_z, out vec3 w) {
    bool back;
    return sample_hit(a, b, c, o, d, depth_z, w, back);
}

#endif
