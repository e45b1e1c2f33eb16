#version 460
// Depth peeling (engine/src/techniques/oit.rs), layer `layer`: of the transparent surfaces in front of
// the opaque depth and strictly behind the previous layer's depth, the nearest wins the depth test
// (GREATER, reversed Z) and writes its premultiplied colour alpha * C and its transmittance
// (1 - alpha) * tint. With MSAA the pipeline shades per sample (sample-rate shading) and compares the
// depths of its own sample (gl_SampleID), so every sample peels its own layers.
//
// The depth written is gl_FragCoord.z, the value the next layer compares with, so the surface peeled
// here is behind nothing and in front of nothing in the next layer: it is excluded exactly, without a
// bias. Surfaces that do nothing (alpha 0, white tint) take no layer.
// SHADOWS: the shadow maps as set 4 (set 3 is this pipeline's own).
#define SHADOW_SET 4
#include "common/object.glsl"
#include "common/shading.glsl"
#include "oit/draw.glsl"

#ifdef MULTISAMPLED
layout(set = 3, binding = 0) uniform sampler2DMS opaque_depth;
layout(set = 3, binding = 1) uniform sampler2DMS previous_depth;
#define DEPTH_AT(map) texelFetch(map, ivec2(gl_FragCoord.xy), gl_SampleID).r
#else
layout(set = 3, binding = 0) uniform sampler2D opaque_depth;
layout(set = 3, binding = 1) uniform sampler2D previous_depth;
#define DEPTH_AT(map) texelFetch(map, ivec2(gl_FragCoord.xy), 0).r
#endif

layout(location = 0) out vec4 out_color;          // rgb: alpha * C
layout(location = 1) out vec4 out_transmittance;  // rgb: (1 - alpha) * tint

void main() {
    pass_texture_begin(v_uv, pc.texture_footprint);
    OIT_SHADOW_PLANE();
    float z = gl_FragCoord.z;
    // Reversed Z: nearer is greater.
    if (!(z > DEPTH_AT(opaque_depth))) discard;
    if (pc.layer > 0u && !(z < DEPTH_AT(previous_depth))) discard;
    Material m = materials[pc.object];
    float alpha = oit_alpha(m);
    if (oit_degenerate() || (alpha <= 0.0 && pc.tint.rgb == vec3(1.0))) discard;
    out_color = vec4(alpha * oit_shade(m), 1.0);
    out_transmittance = vec4((1.0 - alpha) * pc.tint.rgb, 1.0);
    gl_FragDepth = z;
}
