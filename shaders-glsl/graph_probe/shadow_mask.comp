#version 460
// The graph probe's compute pass between draws (engine/src/techniques/graph_probe.rs): per pixel, the
// view depth of the camera's depth pre-pass and whether that point is lit in the light's shadow map.
// Set 0 is the camera's frame (its viewport and lens); set 3 the two depth images and the output.
#include "common/frame.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 3, binding = 0) uniform sampler2D camera_depth;
layout(set = 3, binding = 1) uniform sampler2D shadow_depth;
layout(set = 3, binding = 2, std430) writeonly buffer Mask { vec2 mask[]; };  // view depth (0: none), lit

layout(push_constant) uniform Push {
    mat4 camera_to_light;  // camera space -> the light view's space
    vec4 light;            // orthographic half extents x, y; near, far of the light view
    float bias;            // reversed-depth bias of the shadow test
} pc;

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = ivec2(view.viewport.xy);
    if (any(greaterThanEqual(p, size))) return;
    uint i = uint(p.y * size.x + p.x);
    float d = texelFetch(camera_depth, p, 0).r;
    if (d <= 0.0) {
        mask[i] = vec2(0.0, 1.0);
        return;
    }
    // Reversed Z (camera.glsl): d = near (far - z) / ((far - near) z).
    float near_z = view.lens.z, far_z = view.lens.w, s = view.viewport.z;
    float z = near_z * far_z / (near_z + d * (far_z - near_z));
    vec2 tan_xy = vec2((float(p.x) + 0.5 - 0.5 * view.viewport.x) / s, -(float(p.y) + 0.5 - 0.5 * view.viewport.y) / s);
    vec3 camera_point = vec3(tan_xy * z, -z);
    vec3 q = (pc.camera_to_light * vec4(camera_point, 1.0)).xyz;
    vec2 ndc = vec2(q.x / pc.light.x, -q.y / pc.light.y);
    float lit = 1.0;
    if (all(lessThanEqual(abs(ndc), vec2(1.0)))) {
        ivec2 texel = clamp(ivec2((ndc * 0.5 + 0.5) * vec2(textureSize(shadow_depth, 0))), ivec2(0), textureSize(shadow_depth, 0) - 1);
        float occluder = texelFetch(shadow_depth, texel, 0).r;
        float here = (pc.light.w + q.z) / (pc.light.w - pc.light.z);
        lit = here + pc.bias >= occluder ? 1.0 : 0.0;
    }
    mask[i] = vec2(z, lit);
}
