#version 460
// Forward pass fragment stage: the shared shading model, view vector towards this pass' lens sample.
// SHADOWS: lights attenuated by their shadow maps (common/shadow.glsl).
#include "common/object.glsl"
#include "common/shading.glsl"

layout(push_constant) uniform Push {
    uint object;
    float time;
    vec2 lens;
    vec2 jitter;
    uint segment;
    float segment_time;
} pc;

// SAMPLE_RATE: every input interpolated at its sample's position, which makes the stage run per sample
// (GLSL: a `sample` input forces sample-rate evaluation). A pipeline's minSampleShading alone is not
// honoured by every driver (Mesa 22.3.6 lavapipe shaded pinhole once per pixel with it), and shading
// once per pixel leaves a floor in the image that no sample count removes (docs/HARD_CASES.md).
#ifdef SAMPLE_RATE
#define AT_SAMPLE sample
#else
#define AT_SAMPLE
#endif
layout(location = 0) AT_SAMPLE in vec3 v_position;
layout(location = 1) AT_SAMPLE in vec3 v_normal;
layout(location = 2) AT_SAMPLE in vec2 v_uv;
#ifdef SHADOWS
layout(location = 3) AT_SAMPLE in vec3 v_object_position;
layout(location = 4) AT_SAMPLE in vec3 v_object_normal;
#endif
layout(location = 0) out vec4 out_color;

void main() {
    Material m = materials[pc.object];
    // Two-sided: the normal faces the side being seen (the reference flips by the geometric normal).
    vec3 n = normalize(v_normal);
    if (!gl_FrontFacing) n = -n;
    vec3 lens_point = vec3(view.lens.x * pc.lens, 0.0);
    vec3 to_eye = normalize(lens_point - v_position);
    vec3 albedo = m.albedo_specular.rgb;
    if (m.params.y > 0.5) albedo *= texture(albedo_texture, v_uv).rgb;
#ifdef SHADOWS
    shadow_receiver = ShadowReceiver(v_object_position, v_object_normal, pc.segment, pc.segment_time);
#endif
    out_color = vec4(shade(v_position, n, to_eye, albedo, m.albedo_specular.w, m.params.x, pc.time), 1.0);
}
