#version 460
// Interleaved deferred shading (engine/src/techniques/interleaved.rs, the CPU mirror
// engine/src/mirror/interleaved.rs), step 1: the G-buffer of what the pixel's centre sees at mid-shutter
// through the lens centre (forward/forward.vert with no jitter): camera-space position (w = 1 for a
// surface; the clear, 0, is the background), the shading normal facing the viewer, the albedo.
#include "common/frame.glsl"
#include "common/object.glsl"

layout(push_constant) uniform Push {
    uint object;
    float time;
    vec2 lens;
    vec2 jitter;
    uint segment;
    float segment_time;
    float texture_footprint;  // ForwardPush's; 1 here: the G-buffer filters over the whole pixel
} pc;

layout(location = 0) in vec3 v_position;
layout(location = 1) in vec3 v_normal;
layout(location = 2) in vec2 v_uv;
layout(location = 0) out vec4 out_position;
layout(location = 1) out vec4 out_normal;
layout(location = 2) out vec4 out_albedo;

void main() {
    Material m = materials[pc.object];
    // Two-sided, as forward.frag (the reference flips by the geometric normal).
    vec3 n = normalize(v_normal);
    if (!gl_FrontFacing) n = -n;
    vec3 albedo = m.albedo_specular.rgb;
    if (m.params.y > 0.5) albedo *= texture(albedo_texture, v_uv).rgb;
    out_position = vec4(v_position, 1.0);
    out_normal = vec4(n, 0.0);
    out_albedo = vec4(albedo, 1.0);
}
