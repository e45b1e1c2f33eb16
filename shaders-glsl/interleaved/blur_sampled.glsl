#ifndef SHUTTER_INTERLEAVED_BLUR_SAMPLED_GLSL
#define SHUTTER_INTERLEAVED_BLUR_SAMPLED_GLSL
// Interleaved deferred shading, step 6 with the bilinear pairs fetched by the hardware's linear filter
// (the paper's half-texel trick: one fetch for two texels): the body of blur_sampled_x.comp (from
// blur_x_source into blur_mid) and blur_sampled_y.comp (from blur_y_source into texels at pc.dst).
// The kernel, the edges and the pairs are blur.comp's with pc.bilinear = 1 (interleaved::blur_1d): a
// pair (k, k+1) is one textureLod at k + wb/(wa+wb) texels from c, through a linear sampler with
// unnormalized coordinates; the centre and a lone texel are fetched exactly. The hardware quantizes
// the lerp's fraction to subTexelPrecisionBits (8 on lavapipe), so the result differs from the
// shader's lerp by at most 2^-bits of the pair's difference: the test states the bound.
#include "interleaved/common.glsl"

const uint EDGES_IGNORE = 0u;
const uint EDGES_TEXEL = 1u;
const uint EDGES_AXIS = 2u;

float weight(uint k) {
    float sigma = max(float(pc.radius) / 2.0, 0.5);
    return exp(-float(k * k) / (2.0 * sigma * sigma));
}

// Texel `t` along the axis on row/column `o`, exactly.
vec3 fetch(int t, int o) {
    return texelFetch(BLUR_SOURCE, AXIS == 0u ? ivec2(t, o) : ivec2(o, t), 0).rgb;
}

// The linear filter at `x` texels along the axis (texel t's centre is t + 0.5) on row/column `o`.
vec3 filtered(float x, int o) {
    return textureLod(BLUR_SOURCE, AXIS == 0u ? vec2(x, float(o) + 0.5) : vec2(float(o) + 0.5, x), 0.0).rgb;
}

bool closed(int e, int o, uint along) {
    uint f = flags[uint(AXIS == 0u ? o : e) * pc.width + uint(AXIS == 0u ? e : o)];
    return pc.edges == EDGES_TEXEL ? f != 0u : (pc.edges == EDGES_AXIS ? (f & along) != 0u : false);
}

void main() {
    uvec2 p = gl_GlobalInvocationID.xy;
    if (any(greaterThanEqual(p, uvec2(pc.width, pc.height)))) return;
    int len = int(AXIS == 0u ? pc.width : pc.height);
    int c = int(AXIS == 0u ? p.x : p.y);
    int o = int(AXIS == 0u ? p.y : p.x);
    uint along = AXIS == 0u ? DIFFERS_X : DIFFERS_Y;
    vec3 sum = weight(0u) * fetch(c, o);
    float total = weight(0u);
    for (int dir = 1; dir >= -1; dir -= 2) {
        for (uint k = 1u; k <= pc.radius; k += 2u) {
            int a = c + dir * int(k);
            bool open_a = a >= 0 && a < len && !closed(dir > 0 ? a - 1 : a, o, along);
            int b = a + dir;
            bool pair = k + 1u <= pc.radius && b >= 0 && b < len;
            if (pair && open_a && !closed(dir > 0 ? b - 1 : b, o, along)) {
                float wa = weight(k), wb = weight(k + 1u);
                sum += (wa + wb) * filtered(float(a) + 0.5 + float(dir) * (wb / (wa + wb)), o);
                total += wa + wb;
            } else if (!pair && open_a) {
                sum += weight(k) * fetch(a, o);
                total += weight(k);
            } else {
                break;
            }
        }
    }
    STORE(p, sum / total);
}
#endif
