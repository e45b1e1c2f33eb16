#version 460
// Pass 1 of adaptive texture-space shading, fragment stage: one texel of the shading atlas shaded at
// its surface point — at the lens centre and mid-shutter (view-independent as in the paper: the eye
// is the lens centre for every sample that later looks this texel up). Alpha marks which sub-pass
// wrote the texel: 1 the shade sub-pass, 0.5 the conservative one (tests read it; pass 2 ignores it).
// Material textures are read at their base level, bilinear, as the reference does: the paper's
// pre-filter over (x, y, u, v, t) (texture_space::filter) is not applied yet (docs/ATSS.md).
//   INSTRUMENTED: counts the texels each sub-pass shades (set 3, binding 2). Depth is tested before
//     the fragment stage runs (early_fragment_tests: this stage neither discards nor writes depth),
//     so a hull texel behind an already shaded one is neither shaded nor counted.
#include "common/frame.glsl"
#include "common/object.glsl"
#include "common/shading.glsl"
#include "common/texture_sample.glsl"
#include "texture_space/atlas_push.glsl"

layout(location = 0) in vec3 g_position;
layout(location = 1) in vec3 g_normal;
layout(location = 2) in vec2 g_uv;
layout(location = 0) out vec4 out_color;

layout(early_fragment_tests) in;

#ifdef INSTRUMENTED
layout(set = 3, binding = 2, std430) buffer AtlasCounters {
    uint shaded_texels;  // by the shade sub-pass
    uint gutter_texels;  // by the conservative sub-pass
} counters;
#endif

void main() {
    Material m = materials[pc.object];
    vec3 n = dot(g_normal, g_normal) > 0.0 ? normalize(g_normal) : vec3(0.0, 0.0, 1.0);
    vec3 to_eye = normalize(-g_position);
    // Two-sided: the side facing the lens centre.
    if (dot(n, to_eye) < 0.0) n = -n;
    vec3 albedo = m.albedo_specular.rgb;
    if (m.params.y > 0.5) albedo *= texture_bilinear(g_uv);
#ifdef CONSERVATIVE
    float marker = 0.5;
#else
    float marker = 1.0;
#endif
#ifdef INSTRUMENTED
#ifdef CONSERVATIVE
    atomicAdd(counters.gutter_texels, 1u);
#else
    atomicAdd(counters.shaded_texels, 1u);
#endif
#endif
    out_color = vec4(shade(g_position, n, to_eye, albedo, m.albedo_specular.w, m.params.x, pc.time), marker);
}
