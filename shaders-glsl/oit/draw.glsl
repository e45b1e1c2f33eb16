// What every OIT draw shares (engine/src/techniques/oit.rs, OitPush): forward.vert's push members
// first (it reads them), then what coverage, the stochastic depths and peeling need; the coverage of
// a fragment; and the one call of the shading model (forward.frag's), kept in one place.
#ifndef SHUTTER_OIT_DRAW_GLSL
#define SHUTTER_OIT_DRAW_GLSL

layout(push_constant) uniform Push {
    uint object;
    float time;
    vec2 lens;
    vec2 jitter;
    uint segment;
    float segment_time;
    vec4 tint;            // rgb: the object's tint (transmission); w unused
    uint coverage_seed;   // transparency::coverage_seed of the render seed
    uint samples;         // S: samples per pixel over the whole frame (MSAA x passes)
    uint sample_base;     // index among the S of this pass' first MSAA sample (pass x MSAA)
    uint msaa;            // MSAA samples of this pass
    uint first_triangle;  // the object's first triangle in the scene's numbering (the reference's)
    uint alpha_from_texture;
    uint channel;         // stochastic depth: 0-2 the channel whose effective coverage decides, 3: alpha
    uint depth_maps;      // layers: 1 (no tinted object) or 3 stochastic depth maps (one per channel)
    uint layer;           // peeling: the layer being peeled, 0 the nearest
    float texture_footprint;  // sampling::pass_texture_footprint (common/pass_texture.glsl)
} pc;

layout(location = 0) in vec3 v_position;
layout(location = 1) in vec3 v_normal;
layout(location = 2) in vec2 v_uv;
#ifdef SHADOWS
layout(location = 3) in vec3 v_object_position;
layout(location = 4) in vec3 v_object_normal;
// The fragment's triangle normal (object space) for the shadow lookup: each main() sets it first,
// before any discard (derivatives need the whole quad).
vec3 oit_plane_normal = vec3(0.0);
#define OIT_SHADOW_PLANE() oit_plane_normal = shadow_plane_normal(v_object_position)
#else
#define OIT_SHADOW_PLANE()
#endif

#include "common/pass_texture.glsl"
// Each main() calls pass_texture_begin(v_uv, pc.texture_footprint) first, before any discard.

// Coverage alpha (x the texture's alpha when the material takes it from there), as transparent.frag.
float oit_alpha(Material m) {
    float alpha = m.params.z;
    if (pc.alpha_from_texture != 0u) alpha *= pass_texture(v_uv).a;
    return alpha;
}

// Per channel, the probability that the surface stops light: 1 - (1 - alpha) * tint. Exactly alpha
// (the same float, hence the same coverage decision) where the tint is 1.
vec3 oit_effective_coverage(float alpha) {
    vec3 a;
    for (int c = 0; c < 3; ++c) a[c] = pc.tint[c] == 1.0 ? alpha : 1.0 - (1.0 - alpha) * pc.tint[c];
    return a;
}

#ifdef SHUTTER_SHADING_GLSL
// forward.frag's shading of this fragment.
vec3 oit_shade(Material m) {
    vec3 n = normalize(v_normal);
    if (!gl_FrontFacing) n = -n;
    vec3 lens_point = vec3(view.lens.x * pc.lens, 0.0);
    vec3 to_eye = normalize(lens_point - v_position);
    vec3 albedo = m.albedo_specular.rgb;
    if (m.params.y > 0.5) albedo *= pass_texture(v_uv).rgb;
#ifdef SHADOWS
    shadow_receiver = ShadowReceiver(v_object_position, v_object_normal, oit_plane_normal, pc.segment, pc.segment_time);
#endif
    return shade(v_position, n, to_eye, albedo, m.albedo_specular.w, m.params.x, pc.time);
}
#endif

// Reading forward.vert's other outputs keeps the stage interface whole (the validation layer reports
// outputs a fragment stage does not consume); a NaN vertex draws nothing anyway.
bool oit_degenerate() {
    return any(isnan(v_position)) || any(isnan(v_normal));
}

#endif
