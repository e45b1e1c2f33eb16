#version 460
// Forward pass fragment stage: the shared shading model, view vector towards this pass' lens sample.
#include "common/shading.glsl"

layout(set = 1, binding = 0) uniform sampler2D albedo_texture;

layout(push_constant) uniform Push {
    uint object;
    float time;
    vec2 lens;
    vec2 jitter;
} pc;

layout(location = 0) in vec3 v_position;
layout(location = 1) in vec3 v_normal;
layout(location = 2) in vec2 v_uv;
layout(location = 0) out vec4 out_color;

void main() {
    ObjectData o = objects[pc.object];
    // Two-sided: the normal faces the side being seen (the reference flips by the geometric normal).
    vec3 n = normalize(v_normal);
    if (!gl_FrontFacing) n = -n;
    vec3 lens_point = vec3(frame.lens.x * pc.lens, 0.0);
    vec3 view = normalize(lens_point - v_position);
    vec3 albedo = o.albedo_specular.rgb;
    if (o.material.y > 0.5) albedo *= texture(albedo_texture, v_uv).rgb;
    out_color = vec4(shade(v_position, n, view, albedo, o.albedo_specular.w, o.material.x, pc.time), 1.0);
}
