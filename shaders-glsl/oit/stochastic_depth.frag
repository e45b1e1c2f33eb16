#version 460
// Depth-based stochastic transparency, pass 1 (engine/src/techniques/oit.rs): depth only. A transparent
// surface writes its depth to the MSAA samples its stochastic coverage mask keeps — the mask of
// forward/transparent.frag, from common/coverage.glsl — so each sample ends with the nearest surface
// that covers it and the pixel's M samples are M draws of the deep shadow function from the eye.
//
// Tinted scenes draw this three times, `channel` 0-2, each with the per-channel effective coverage
// 1 - (1 - alpha) * tint (oit.rs explains why); an untinted one once with alpha (`channel` 3).
//
// The depth written is the fragment's centre depth (gl_FragCoord.z) on every sample it keeps, so that
// the layers pass, which shades once per fragment and compares that same centre depth, finds its own
// surface exactly at its depth rather than in front of or behind it by the slope across the pixel.
#include "common/frame.glsl"
#include "common/object.glsl"
#include "common/coverage.glsl"
#include "oit/draw.glsl"

void main() {
    pass_texture_begin(v_uv, pc.texture_footprint);
    Material m = materials[pc.object];
    float alpha = oit_alpha(m);
    float coverage = pc.channel < 3u ? oit_effective_coverage(alpha)[pc.channel] : alpha;
    uint key = coverage_key(pc.coverage_seed, uvec2(gl_FragCoord.xy), pc.first_triangle + uint(gl_PrimitiveID));
    uint mask = coverage_mask(key, coverage, pc.samples, pc.sample_base, pc.msaa);
    if (oit_degenerate()) mask = 0u;
    if (mask == 0u) discard;
    gl_SampleMask[0] = int(mask);
    gl_FragDepth = gl_FragCoord.z;
}
