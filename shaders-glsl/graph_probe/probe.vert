#version 460
// The graph probe's vertex stage (engine/src/techniques/graph_probe.rs): forward.vert's transform
// through any view's projection (view_clip: the camera's thin lens, or a light's orthographic view),
// so one shader draws the camera's depth pre-pass, the light's shadow map and the colour pass, and
// the depth the colour pass tests EQUAL against is bit-identical to the pre-pass'.
#include "common/camera.glsl"

layout(location = 0) in vec3 in_position;
layout(location = 1) in vec3 in_normal;
layout(location = 2) in vec2 in_uv;

layout(push_constant) uniform Push {
    uint object;
    float time;
    vec2 lens;
    vec2 jitter;
    uint segment;
    float segment_time;
    float texture_footprint;  // ForwardPush's; unused here
} pc;

layout(location = 0) out vec3 v_position;
layout(location = 1) out vec3 v_normal;
layout(location = 2) out vec2 v_uv;

void main() {
    ObjectView o = object_views[pc.segment];
    vec3 p0 = (o.model_view[0] * vec4(in_position, 1.0)).xyz;
    vec3 p1 = (o.model_view[1] * vec4(in_position, 1.0)).xyz;
    vec3 p = p0 + (p1 - p0) * pc.segment_time;  // exact for a still vertex (MovingTriangle::at)
    v_position = p;
    v_normal = mix(mat3(o.normal_matrix[0]) * in_normal, mat3(o.normal_matrix[1]) * in_normal, pc.segment_time);
    v_uv = in_uv;
    gl_Position = view_clip(p, pc.lens, pc.jitter);
}
