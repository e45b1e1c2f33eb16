#version 460
// Forward pass vertex stage: one (u,v,t) per draw (pinhole and accumulation passes), through any
// view's projection (the camera's thin lens; a light's, for its shadow map).
// View-space position at t is the lerp of the positions at shutter open and close (docs/MODEL.md).
// SHADOW_RECEIVER: also the object-space position and normal, for common/shadow.glsl's lookups.
#include "common/camera.glsl"

layout(location = 0) in vec3 in_position;
layout(location = 1) in vec3 in_normal;
layout(location = 2) in vec2 in_uv;

layout(push_constant) uniform Push {
    uint object;
    float time;
    vec2 lens;    // unit aperture coordinates (already mapped to the aperture shape)
    vec2 jitter;  // subpixel offset of this pass, pixels
    uint segment;        // the object's key segment holding `time` (index into object_views)
    float segment_time;  // the time within it
    float texture_footprint;  // the fragment stage's (common/pass_texture.glsl)
} pc;

layout(location = 0) out vec3 v_position;  // camera space at t
layout(location = 1) out vec3 v_normal;
layout(location = 2) out vec2 v_uv;
#ifdef SHADOW_RECEIVER
layout(location = 3) out vec3 v_object_position;
layout(location = 4) out vec3 v_object_normal;
#endif

void main() {
    ObjectView o = object_views[pc.segment];
    vec3 p0 = (o.model_view[0] * vec4(in_position, 1.0)).xyz;
    vec3 p1 = (o.model_view[1] * vec4(in_position, 1.0)).xyz;
    vec3 p = p0 + (p1 - p0) * pc.segment_time;  // exact for a still vertex (MovingTriangle::at)
    v_position = p;
    v_normal = mix(mat3(o.normal_matrix[0]) * in_normal, mat3(o.normal_matrix[1]) * in_normal, pc.segment_time);
    v_uv = in_uv;
#ifdef SHADOW_RECEIVER
    v_object_position = in_position;
    v_object_normal = in_normal;
#endif
    gl_Position = view_clip(p, pc.lens, pc.jitter);
}
