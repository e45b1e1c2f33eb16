#version 460
// Stochastic transparency on the forward path (techniques/forward.rs, docs/TRANSPARENCY.md): a
// surface with coverage alpha < 1 keeps the samples common/coverage.glsl gives it — visibility first,
// so a fragment covering none of its samples is discarded before shading — and is otherwise shaded
// once per fragment like forward.frag.
//
// TINT_PASS: drawn after every surface of the pass, depth test against the stored depth (nearer
// only), no depth write, multiplicative blending: it writes the tint to exactly the samples the
// surface does NOT cover, so each sample ends as the product of the tints in front of its visible
// surface times that surface's colour.
#include "common/object.glsl"
#include "common/shading.glsl"
#include "common/coverage.glsl"
#include "common/pass_texture.glsl"

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
    float alpha = m.params.z;
    if (pc.alpha_from_texture != 0u) alpha *= pass_texture(v_uv).a;
    uint key = coverage_key(pc.coverage_seed, uvec2(gl_FragCoord.xy), pc.first_triangle + uint(gl_PrimitiveID));
    uint covered = coverage_mask(key, alpha, pc.samples, pc.sample_base, pc.msaa);
#ifdef TINT_PASS
    uint mask = ~covered & ((1u << pc.msaa) - 1u);
    // Reading forward.vert's other outputs keeps the stage interface whole (the validation layer
    // reports outputs a fragment stage does not consume); a NaN vertex would tint nothing anyway.
    if (any(isnan(v_position)) || any(isnan(v_normal))) mask = 0u;
    if (mask == 0u) discard;
    gl_SampleMask[0] = int(mask);
    out_color = vec4(pc.tint.rgb, 1.0);
#else
    if (covered == 0u) discard;
    gl_SampleMask[0] = int(covered);
    // The shading of forward.frag.
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
#endif
}
