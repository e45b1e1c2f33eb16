#version 460
// The mask coverage path's resolve (engine/src/techniques/stochastic/mask.rs): the multisampled payload
// and depth the hardware's per-sample depth test left (mask.frag) into the visibility buffer's words
// (stochastic/visibility.glsl) — ~bits(view depth) << 32 | payload per hit, 0 where nothing was drawn —
// so the shading stages read one buffer whichever coverage path filled it. Plain 64-bit stores, no
// atomics: every word of the pass is written once.
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
layout(local_size_x = 8, local_size_y = 8) in;

layout(push_constant) uniform Push {
    uint width;
    uint height;
    uint per_pass;  // M: the target's samples, the visibility buffer's words per pixel
} pc;

layout(set = 3, binding = 5, std430) writeonly buffer Visibility { uint64_t visibility[]; };
#ifdef MASK_SINGLE_SAMPLE
// M = 1: the target has one sample per pixel, which a multisampled sampler may not read.
layout(set = 3, binding = 12) uniform usampler2D mask_payload;
layout(set = 3, binding = 13) uniform sampler2D mask_depth;
#else
layout(set = 3, binding = 12) uniform usampler2DMS mask_payload;
layout(set = 3, binding = 13) uniform sampler2DMS mask_depth;
#endif

// mask.frag's MASK_DEPTH_SCALE, inverted: 2^32, exact.
const float MASK_DEPTH_UNSCALE = 4294967296.0;

void main() {
    uvec2 pix = gl_GlobalInvocationID.xy;
    if (pix.x >= pc.width || pix.y >= pc.height) return;
    for (uint i = 0u; i < pc.per_pass; i++) {
        // The sample index of a multisampled target; level 0 of a single-sampled one (i = 0 there).
        float d = texelFetch(mask_depth, ivec2(pix), int(i)).r;
        uint payload = texelFetch(mask_payload, ivec2(pix), int(i)).r;
        uint at = (pix.y * pc.width + pix.x) * pc.per_pass + i;
        uint64_t word = 0UL;
        if (d < 1.0) {
            uint bits = floatBitsToUint(d * MASK_DEPTH_UNSCALE);
            word = (uint64_t(~bits) << 32) | uint64_t(payload);
        }
        visibility[at] = word;
    }
}
