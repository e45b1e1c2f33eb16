#version 460
// Depth-based stochastic transparency, pass 2 (engine/src/techniques/oit.rs): every transparent
// fragment in front of the opaque depth (the attachment, read only) adds, with additive blending,
//   out_sum    += vis(z) * alpha * C           (per channel)
//   out_weight += vis(z) * effective coverage  (per channel; its exact sum is 1 - total transmittance)
// where vis(z) is the fraction of the pixel's stochastic depths (pass 1, this pass' M samples) that
// are not nearer than the fragment: an estimate of the light that reaches the eye from depth z. Shaded
// once per fragment. Tinted scenes have one stochastic depth map per channel, so vis is per channel.
// The third attachment (the total transmittance, multiplied by transmittance.frag in the same
// rendering) gets 0, which additive blending leaves unchanged.
// SHADOWS: the shadow maps as set 4 (set 3 is this pipeline's own).
#define SHADOW_SET 4
#include "common/object.glsl"
#include "common/shading.glsl"
#include "oit/draw.glsl"

#ifdef MULTISAMPLED
layout(set = 3, binding = 0) uniform sampler2DMS stochastic_depth_r;
layout(set = 3, binding = 1) uniform sampler2DMS stochastic_depth_g;
layout(set = 3, binding = 2) uniform sampler2DMS stochastic_depth_b;
#define DEPTH_AT(map, s) texelFetch(map, ivec2(gl_FragCoord.xy), int(s)).r
#else
layout(set = 3, binding = 0) uniform sampler2D stochastic_depth_r;
layout(set = 3, binding = 1) uniform sampler2D stochastic_depth_g;
layout(set = 3, binding = 2) uniform sampler2D stochastic_depth_b;
#define DEPTH_AT(map, s) texelFetch(map, ivec2(gl_FragCoord.xy), 0).r
#endif

layout(location = 0) out vec4 out_sum;
layout(location = 1) out vec4 out_weight;
layout(location = 2) out vec4 out_transmittance;

// Reversed Z: nearer is greater. A stored depth up to a relative 2^-20 in front of the fragment counts
// as not nearer: the fragment's own surface stored this very depth, and the neighbouring triangle of
// the same flat mesh may have rounded its plane an ulp nearer.
#define NOT_NEARER(d, z) ((d) <= (z) + (z) * (1.0 / 1048576.0))

void main() {
    pass_texture_begin(v_uv, pc.texture_footprint);
    OIT_SHADOW_PLANE();
    Material m = materials[pc.object];
    float alpha = oit_alpha(m);
    float z = gl_FragCoord.z;
    vec3 unoccluded = vec3(0.0);
    for (uint s = 0u; s < pc.msaa; ++s) {
        unoccluded.r += NOT_NEARER(DEPTH_AT(stochastic_depth_r, s), z) ? 1.0 : 0.0;
        if (pc.depth_maps == 3u) {
            unoccluded.g += NOT_NEARER(DEPTH_AT(stochastic_depth_g, s), z) ? 1.0 : 0.0;
            unoccluded.b += NOT_NEARER(DEPTH_AT(stochastic_depth_b, s), z) ? 1.0 : 0.0;
        }
    }
    if (pc.depth_maps != 3u) unoccluded = unoccluded.rrr;
    vec3 vis = unoccluded / float(pc.msaa);
    vec3 c = oit_degenerate() ? vec3(0.0) : oit_shade(m);
    out_sum = vec4(vis * alpha * c, 0.0);
    out_weight = vec4(vis * oit_effective_coverage(alpha), 0.0);
    out_transmittance = vec4(0.0);
}
