#version 460
// Depth-based stochastic transparency, the total transmittance (engine/src/techniques/oit.rs): drawn
// in the layers pass' rendering after layers.frag, in front of the opaque depth only, with
// multiplicative blending: the third attachment ends as the product of (1 - alpha) * tint over every
// transparent surface in front of the opaque one — exact, and order independent because a product is —
// and its alpha the product of (1 - alpha) alone: 1 minus the exact total alpha, which alpha-corrected
// stochastic transparency rescales its count to. The two sums get 1, which multiplicative blending
// leaves unchanged. (Alpha-corrected ST draws it first in its own pass, before its coverage draws
// write their depth.)
#include "common/frame.glsl"
#include "common/object.glsl"
#include "oit/draw.glsl"

layout(location = 0) out vec4 out_sum;
layout(location = 1) out vec4 out_weight;
layout(location = 2) out vec4 out_transmittance;

void main() {
    pass_texture_begin(v_uv, pc.texture_footprint);
    Material m = materials[pc.object];
    float alpha = oit_alpha(m);
    bool skip = oit_degenerate();
    vec3 t = skip ? vec3(1.0) : (1.0 - alpha) * pc.tint.rgb;
    out_sum = vec4(1.0);
    out_weight = vec4(1.0);
    out_transmittance = vec4(t, skip ? 1.0 : 1.0 - alpha);
}
