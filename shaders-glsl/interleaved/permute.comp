#version 460
// Interleaved deferred shading, steps 2 and 4: one permutation of the padded layout's texels
// (pc.stride vec4s each) from pc.src to pc.dst by the map pc.map — pushed (dst[map(p)] = src[p]: the
// split) or pulled (dst[p] = src[map(p)]: the gather, its inverse). The one-pass split is MAP_SPLIT;
// the two-pass split MAP_BLOCK_SPLIT then MAP_BLOCK_TRANSLATE (interleaved::split_two_pass); the
// gathers pull MAP_SPLIT, or MAP_BLOCK_TRANSLATE then MAP_BLOCK_SPLIT (interleaved::gather_two_pass).
#include "interleaved/common.glsl"

void main() {
    uvec2 p = gl_GlobalInvocationID.xy;
    if (any(greaterThanEqual(p, uvec2(pc.padded_w, pc.padded_h)))) return;
    uvec2 q = pc.map == MAP_SPLIT ? split_of(p) : (pc.map == MAP_BLOCK_SPLIT ? block_split_of(p) : block_translate_of(p));
    uint a = p.y * pc.padded_w + p.x, b = q.y * pc.padded_w + q.x;
    uint from = pc.pull == 1u ? b : a, to = pc.pull == 1u ? a : b;
    for (uint k = 0u; k < pc.stride; k++) texels[pc.dst + pc.stride * to + k] = texels[pc.src + pc.stride * from + k];
}
