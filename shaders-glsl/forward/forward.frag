#version 460
// Forward pass fragment stage: the shared shading model, view vector towards this pass' lens sample;
// textures filtered over the pass' share of the pixel (common/pass_texture.glsl).
// SHADOWS: lights attenuated by their shadow maps (common/shadow.glsl).
#include "common/object.glsl"
#include "common/shading.glsl"
#include "common/pass_texture.glsl"

layout(push_constant) uniform Push {
    uint object;
    float time;
    vec2 lens;
    vec2 jitter;
    uint segment;
    float segment_time;
    float texture_footprint;  // sampling::pass_texture_footprint (common/pass_texture.glsl)
} pc;

layout(location = 0) in vec3 v_position;
layout(location = 1) in vec3 v_normal;
layout(location = 2) in vec2 v_uv;
#ifdef SHADOWS
layout(location = 3) in vec3 v_object_position;
layout(location = 4) in vec3 v_object_normal;
#endif
layout(location = 0) out vec4 out_color;

void main() {
    pass_texture_begin(v_uv, pc.texture_footprint);
#ifdef SHADOWS
    // Before any discard: derivatives need the whole quad.
    vec3 plane_normal = shadow_plane_normal(v_object_position);
#endif
    Material m = materials[pc.object];
    // Two-sided: the normal faces the side being seen (the reference flips by the geometric normal).
    vec3 n = normalize(v_normal);
    if (!gl_FrontFacing) n = -n;
    vec3 lens_point = vec3(view.lens.x * pc.lens, 0.0);
    vec3 to_eye = normalize(lens_point - v_position);
    vec3 albedo = m.albedo_specular.rgb;
    if (m.params.y > 0.5) albedo *= pass_texture(v_uv).rgb;
#ifdef SHADOWS
    shadow_receiver = ShadowReceiver(v_object_position, v_object_normal, plane_normal, pc.segment, pc.segment_time);
#endif
    out_color = vec4(shade(v_position, n, to_eye, albedo, m.albedo_specular.w, m.params.x, pc.time), 1.0);
}
