// Projections of a view: the thin lens, the GLSL mirror of Intrinsics::project
// (engine/src/scene/camera.rs), and the orthographic projection of a light's view.
#ifndef SHUTTER_CAMERA_GLSL
#define SHUTTER_CAMERA_GLSL
#include "common/frame.glsl"

// Clip-space position of camera-space point p seen through lens sample `lens_unit` (unit aperture
// coordinates), shifted by `jitter_px` pixels (the framebuffer shows true pixel position - jitter).
// Screen position = pinhole projection + phi(z) * lens, phi(z) = A s (1/F - 1/z) (docs/MODEL.md).
// Depth is reversed Z between near (1) and far (0); everything stays linear in p, so attributes
// interpolate perspective-correctly and motion (linear in camera space) stays linear in clip space.
vec4 thin_lens_clip(vec3 p, vec2 lens_unit, vec2 jitter_px) {
    float W = view.viewport.x, H = view.viewport.y, s = view.viewport.z;
    float A = view.lens.x, F = view.lens.y, near_z = view.lens.z, far_z = view.lens.w;
    float z = -p.z;
    vec2 L = A * lens_unit;
    vec2 qz = (p.xy - L) + L * (z / F);  // focus-plane point (tan space) times z
    vec4 clip;
    clip.x = (2.0 * s * qz.x - 2.0 * jitter_px.x * z) / W;
    clip.y = (-2.0 * s * qz.y - 2.0 * jitter_px.y * z) / H;
    clip.z = near_z * (far_z - z) / (far_z - near_z);
    // Exactly, 0 <= clip.z <= w on [near, far]; rounding could push a vertex lying exactly on the near
    // plane out of the clip volume and drop a face the reference keeps, and a face exactly on the far
    // plane has depth 0, which fails the GREATER test against the cleared 0. Both are kept a relative
    // 2^-20 of view depth inside: depth 1 - 2^-20 (the rasterizer's interpolated depth of a face at
    // exactly 1 also rounds above 1 here and there), and at the far end the depth of
    // z = far (1 - 2^-20), about near / (far - near) 2^-20, not 2^-20 itself: depth falls like
    // near / z, so an absolute floor of 2^-20 flattened everything beyond near 2^20 into one depth
    // (1 km at near = 1 mm). Intrinsics::reversed_z (engine/src/scene/camera.rs) mirrors this.
    if (z >= near_z) clip.z = min(clip.z, z * (1.0 - 1.0 / 1048576.0));
    if (z <= far_z) clip.z = max(clip.z, z * (near_z / (far_z - near_z) * (1.0 / 1048576.0)));
    clip.w = z;
    return clip;
}

// Clip-space position of view-space point p in an orthographic view (a directional light's shadow
// map; engine/src/scene/view.rs): x, y over the half extents, reversed-Z depth linear from near (1)
// to far (0).
vec4 orthographic_clip(vec3 p) {
    float near_z = view.lens.z, far_z = view.lens.w;
    return vec4(p.x / view.projection.y, -p.y / view.projection.z, (far_z + p.z) / (far_z - near_z), 1.0);
}

// Clip-space position of view-space point p in a pinhole perspective view (a spot light's shadow map
// or a face of a point light's; engine/src/scene/view.rs Projection::Perspective): the thin lens'
// projection without a lens or jitter, the same reversed-Z depth.
vec4 perspective_clip(vec3 p) {
    float W = view.viewport.x, H = view.viewport.y, s = view.viewport.z;
    float near_z = view.lens.z, far_z = view.lens.w;
    float z = -p.z;
    return vec4(2.0 * s * p.x / W, -2.0 * s * p.y / H, near_z * (far_z - z) / (far_z - near_z), z);
}

// Any view: its thin lens, or a light's orthographic or perspective projection, as the view's block
// says.
vec4 view_clip(vec3 p, vec2 lens_unit, vec2 jitter_px) {
    if (view.projection.x == PROJECTION_ORTHOGRAPHIC) return orthographic_clip(p);
    if (view.projection.x == PROJECTION_PERSPECTIVE) return perspective_clip(p);
    return thin_lens_clip(p, lens_unit, jitter_px);
}

#endif
