#version 460
// Interleaved deferred shading, step 6: one direction (pc.axis) of the edge-aware separable Gaussian
// (interleaved::blur_1d, operation for operation), from pc.src to pc.dst (one vec4 per texel, rows of
// pc.padded_w, the image's pc.width × pc.height used). Weights exp(−k²/2σ²), σ = max(radius/2, 1/2).
// From texel c the kernel extends each way while no edge it crosses is closed: going +, the flags of
// c … c+k−1; going −, those of c−k … c−1 (EDGES_TEXEL: any flag bit, the paper's rule; EDGES_AXIS:
// the bit of this axis; EDGES_IGNORE: none). pc.bilinear: the texels in pairs (k, k+1), each pair one
// weighted lerp counted only when both are reachable (here two loads and a lerp: the buffer has no
// sampler, so the pairs cost what the single texels do).
#include "interleaved/common.glsl"

const uint EDGES_IGNORE = 0u;
const uint EDGES_TEXEL = 1u;
const uint EDGES_AXIS = 2u;

float weight(uint k) {
    float sigma = max(float(pc.radius) / 2.0, 0.5);
    return exp(-float(k * k) / (2.0 * sigma * sigma));
}

void main() {
    uvec2 p = gl_GlobalInvocationID.xy;
    if (any(greaterThanEqual(p, uvec2(pc.width, pc.height)))) return;
    int len = int(pc.axis == 0u ? pc.width : pc.height);
    int c = int(pc.axis == 0u ? p.x : p.y);
    uint along = pc.axis == 0u ? DIFFERS_X : DIFFERS_Y;
    vec3 sum = weight(0u) * texels[pc.src + p.y * pc.padded_w + p.x].rgb;
    float total = weight(0u);
    for (int dir = 1; dir >= -1; dir -= 2) {
        bool open = true;
        for (uint k = 1u; k <= pc.radius; k += (pc.bilinear == 1u ? 2u : 1u)) {
            int a = c + dir * int(k);
            int edge_a = dir > 0 ? a - 1 : a;
            uvec2 qa = pc.axis == 0u ? uvec2(uint(max(a, 0)), p.y) : uvec2(p.x, uint(max(a, 0)));
            uvec2 ea = pc.axis == 0u ? uvec2(uint(max(edge_a, 0)), p.y) : uvec2(p.x, uint(max(edge_a, 0)));
            uint fa = flags[ea.y * pc.width + ea.x];
            bool closed_a = pc.edges == EDGES_TEXEL ? fa != 0u : (pc.edges == EDGES_AXIS ? (fa & along) != 0u : false);
            bool open_a = open && a >= 0 && a < len && !closed_a;
            vec3 va = open_a ? texels[pc.src + qa.y * pc.padded_w + qa.x].rgb : vec3(0.0);
            if (pc.bilinear == 0u) {
                if (!open_a) break;
                sum += weight(k) * va;
                total += weight(k);
                open = open_a;
                continue;
            }
            int b = a + dir;
            bool pair = k + 1u <= pc.radius && b >= 0 && b < len;
            int edge_b = dir > 0 ? b - 1 : b;
            uvec2 qb = pc.axis == 0u ? uvec2(uint(clamp(b, 0, len - 1)), p.y) : uvec2(p.x, uint(clamp(b, 0, len - 1)));
            uvec2 eb = pc.axis == 0u ? uvec2(uint(clamp(edge_b, 0, len - 1)), p.y) : uvec2(p.x, uint(clamp(edge_b, 0, len - 1)));
            uint fb = flags[eb.y * pc.width + eb.x];
            bool closed_b = pc.edges == EDGES_TEXEL ? fb != 0u : (pc.edges == EDGES_AXIS ? (fb & along) != 0u : false);
            bool open_b = open_a && pair && !closed_b;
            if (pair && open_b) {
                float wa = weight(k), wb = weight(k + 1u);
                vec3 vb = texels[pc.src + qb.y * pc.padded_w + qb.x].rgb;
                sum += (wa + wb) * mix(va, vb, wb / (wa + wb));
                total += wa + wb;
                open = open_b;
            } else if (!pair && open_a) {
                sum += weight(k) * va;
                total += weight(k);
                open = open_a;
            } else {
                break;
            }
        }
    }
    texels[pc.dst + p.y * pc.padded_w + p.x] = vec4(sum / total, 0.0);
}
