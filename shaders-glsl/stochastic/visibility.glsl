// The stochastic visibility buffer (engine/src/techniques/stochastic.rs, "visibility first"): one 64-bit
// word per pixel and sample of the current pass, cleared to 0 (no hit). The coverage pass packs each
// hit as (~bits(view depth) << 32) | payload and keeps the largest with atomicMax, i.e. the nearest hit
// by view depth (positive floats order like their bit patterns; ~ turns "nearest" into "largest"),
// ties going to the larger payload. The payload is triangle << 1 | back, the triangle numbered across
// the frame's objects (object i's triangles from pc.triangle_base on) and `back` the side the ray sees
// (the key of per-pixel shading groups with the triangle); the shading pass recomputes everything else
// (barycentrics, time, lens point) from the sample itself.
#ifndef SHUTTER_VISIBILITY_GLSL
#define SHUTTER_VISIBILITY_GLSL
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_EXT_shader_atomic_int64 : require

layout(set = 3, binding = 5, std430) buffer Visibility { uint64_t visibility[]; };

uint64_t visibility_pack(float depth_z, uint triangle, bool back) {
    uint payload = (triangle << 1) | (back ? 1u : 0u);
    return (uint64_t(~floatBitsToUint(depth_z)) << 32) | uint64_t(payload);
}

uint visibility_payload(uint64_t v) {
    return uint(v & 0xffffffffUL);
}

// Index of sample `i` (0 .. per_pass) of pixel `pix` in this pass' buffer.
uint visibility_index(uvec2 pix, uint i, uint per_pass) {
    return (pix.y * uint(view.viewport.x) + pix.x) * per_pass + i;
}

#endif
