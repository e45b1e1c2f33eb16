#version 460
// Pass 1 of adaptive texture-space shading, fragment stage: one texel of the shading atlas shaded at
// its surface point — at the lens centre and mid-shutter (view-independent as in the paper: the eye
// is the lens centre for every sample that later looks this texel up). Alpha marks which sub-pass
// wrote the texel: 1 the shade sub-pass, 0.5 the conservative one (tests read it; pass 2 ignores it).
// Material textures are pre-filtered over the texel's own footprint (common/texture_sample.glsl,
// texture_prefiltered: the uv derivatives across one atlas texel, anisotropic taps of the mip chain).
// A departure from the paper, whose pre-filter is the generalised Loviscach filter over
// (x, y, u, v, t) (texture_space::filter): here every sample looks the atlas up at its own lens point
// and time, so the samples integrate over the lens and the shutter themselves; filtering over them in
// the atlas too would blur twice. The texel footprint already grows with defocus (the level).
//   SHADOWS (SHADOW_MSAA, SHADOW_COLOR): lights attenuated by their shadow maps (set 4) at the
//     texel's surface point at mid-shutter, as the stochastic shading pass does per sample (the maps
//     are rendered once per frame: the stochastic frame takes only still casters).
//   INSTRUMENTED: counts the texels each sub-pass shades (set 3, binding 2). Depth is tested before
//     the fragment stage runs (early_fragment_tests: this stage neither discards nor writes depth),
//     so a hull texel behind an already shaded one is neither shaded nor counted.
// Sets 2 and 3 are this technique's: the shadow maps are set 4 (gpu/layout.rs SHADOW_SET_INDEX).
#define SHADOW_SET 4
#include "common/frame.glsl"
#include "common/object.glsl"
#include "common/shading.glsl"
#include "common/texture_sample.glsl"
#include "texture_space/atlas_push.glsl"

layout(location = 0) in vec3 g_position;
layout(location = 1) in vec3 g_normal;
layout(location = 2) in vec2 g_uv;
#ifdef SHADOWS
layout(location = 3) in vec3 g_object_position;
layout(location = 4) in vec3 g_object_normal;
#endif
layout(location = 0) out vec4 out_color;

layout(early_fragment_tests) in;

#ifdef INSTRUMENTED
layout(set = 3, binding = 2, std430) buffer AtlasCounters {
    uint shaded_texels;  // by the shade sub-pass
    uint gutter_texels;  // by the conservative sub-pass
} counters;
#endif

void main() {
#ifdef SHADOWS
    // Before any discard: derivatives need the whole quad.
    vec3 plane_normal = shadow_plane_normal(g_object_position);
#endif
    Material m = materials[pc.object];
    vec3 n = dot(g_normal, g_normal) > 0.0 ? normalize(g_normal) : vec3(0.0, 0.0, 1.0);
    vec3 to_eye = normalize(-g_position);
    // Two-sided: the side facing the lens centre.
    if (dot(n, to_eye) < 0.0) n = -n;
#ifdef SHADOWS
    shadow_receiver = ShadowReceiver(g_object_position, g_object_normal, plane_normal, pc.segment, pc.segment_time);
#endif
    vec3 albedo = m.albedo_specular.rgb;
    if (m.params.y > 0.5) albedo *= texture_prefiltered(g_uv, dFdx(g_uv), dFdy(g_uv), m.params.w > 0.5);
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
