#version 460
// A partly transmitting shadow caster in a light's shadow-map atlas (engine/src/techniques/shadow_maps.rs,
// docs/SHADOWS.md), drawn by forward.vert through the light's view. Its transmittance per channel is
// tau = (1 - alpha) * tint; it blocks a depth sample with probability 1 - max(tau) (stochastic
// coverage, common/coverage.glsl, keyed on the atlas texel and the triangle), and lets the rest through
// tinted by its hue tau / max(tau), so that the expected light through it is tau per channel.
//
// Depth pass (default): writes depth to the samples it covers (a stochastic shadow map; opaque
// casters are drawn without this stage). HUE_PASS (coloured maps only): drawn after every caster,
// depth-tested against the stored depths (nearer only), no depth write; multiplies its hue into the
// samples it does not cover and raises the colour target's alpha to its depth (max blending), so each
// sample ends holding the product of the hues in front of its stored depth and the nearest of their
// depths (reversed Z: nearest = largest).
#include "common/object.glsl"
#include "common/frame.glsl"
#include "common/coverage.glsl"

layout(push_constant) uniform Push {
    uint object;
    float time;
    vec2 lens;
    vec2 jitter;
    uint segment;
    float segment_time;
    vec4 tint;            // rgb: the object's tint; w unused
    uint coverage_seed;   // this map's seed (shadows::map_seed)
    uint samples;         // S: depth samples per texel (MSAA x sub-maps)
    uint sample_base;     // index among the S of this sub-map's first MSAA sample
    uint msaa;            // MSAA samples of the atlas
    uint first_triangle;  // the object's first triangle in the scene's numbering
    uint alpha_from_texture;
    float texture_footprint;  // TransparentPush's; 1 here: the maps keep the hardware's footprint
} pc;

layout(location = 0) in vec3 v_position;
layout(location = 1) in vec3 v_normal;
layout(location = 2) in vec2 v_uv;
#ifdef HUE_PASS
layout(location = 0) out vec4 out_color;
#endif

void main() {
    Material m = materials[pc.object];
    float alpha = m.params.z;
    if (pc.alpha_from_texture != 0u) alpha *= texture(albedo_texture, v_uv).a;
    vec3 tau = (1.0 - clamp(alpha, 0.0, 1.0)) * pc.tint.rgb;
    float through = max(tau.r, max(tau.g, tau.b));
    // The texel within its tile (tiles lie at multiples of the map's size, view.viewport.x), so that
    // the sub-maps of one face share each texel's key and the stratification spans all S samples;
    // faces (and passes) differ by their seed (shadows::map_seed).
    uvec2 texel = uvec2(gl_FragCoord.xy) % uint(view.viewport.x);
    uint key = coverage_key(pc.coverage_seed, texel, pc.first_triangle + uint(gl_PrimitiveID));
    uint covered = coverage_mask(key, 1.0 - through, pc.samples, pc.sample_base, pc.msaa);
    // The other outputs of forward.vert are read so the stage interface stays whole (a NaN vertex
    // draws nothing anyway).
    if (any(isnan(v_position)) || any(isnan(v_normal))) covered = ~0u;
#ifdef HUE_PASS
    uint mask = ~covered & ((1u << pc.msaa) - 1u);
    if (mask == 0u) discard;
    gl_SampleMask[0] = int(mask);
    out_color = vec4(tau / through, gl_FragCoord.z);
#else
    if (covered == 0u) discard;
    gl_SampleMask[0] = int(covered);
#endif
}
