// Thin-lens projection, the GLSL mirror of Intrinsics::project (engine/src/scene/camera.rs).
#ifndef SHUTTER_CAMERA_GLSL
#define SHUTTER_CAMERA_GLSL
#include "common/frame.glsl"

// Clip-space position of camera-space point p seen through lens sample `lens_unit` (unit aperture
// coordinates), shifted by `jitter_px` pixels (the framebuffer shows true pixel position - jitter).
// Screen position = pinhole projection + phi(z) * lens, phi(z) = A s (1/F - 1/z) (DESIGN.md).
// Depth is reversed Z between near (1) and far (0); everything stays linear in p, so attributes
// interpolate perspective-correctly and motion (linear in camera space) stays linear in clip space.
vec4 thin_lens_clip(vec3 p, vec2 lens_unit, vec2 jitter_px) {
    float W = frame.viewport.x, H = frame.viewport.y, s = frame.viewport.z;
    float A = frame.lens.x, F = frame.lens.y, near_z = frame.lens.z, far_z = frame.lens.w;
    float z = -p.z;
    vec2 L = A * lens_unit;
    vec2 qz = (p.xy - L) + L * (z / F);  // focus-plane point (tan space) times z
    vec4 clip;
    clip.x = (2.0 * s * qz.x - 2.0 * jitter_px.x * z) / W;
    clip.y = (-2.0 * s * qz.y - 2.0 * jitter_px.y * z) / H;
    clip.z = near_z * (far_z - z) / (far_z - near_z);
    clip.w = z;
    return clip;
}

#endif
