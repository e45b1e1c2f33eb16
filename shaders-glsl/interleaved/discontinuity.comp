#version 460
// Interleaved deferred shading, step 5: the discontinuity buffer — per texel of the image, which of its
// three positive neighbours differ from it (interleaved::discontinuities): normals further apart than
// acos(pc.normal_cos), positions further apart than pc.position_rel times the texel's view depth, or a
// surface beside the background.
#include "interleaved/common.glsl"

bool differs(ivec2 a, ivec2 b) {
    vec4 pa = imageLoad(g_position, a), pb = imageLoad(g_position, b);
    bool sa = pa.w > 0.5, sb = pb.w > 0.5;
    if (!sa || !sb) return sa != sb;
    vec3 na = imageLoad(g_normal, a).xyz, nb = imageLoad(g_normal, b).xyz;
    float depth = max(abs(-pa.z), 1e-6);
    return dot(na, nb) < pc.normal_cos || length(pa.xyz - pb.xyz) > pc.position_rel * depth;
}

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = ivec2(pc.width, pc.height);
    if (any(greaterThanEqual(p, size))) return;
    uint bits = 0u;
    if (p.x + 1 < size.x && differs(p, p + ivec2(1, 0))) bits |= DIFFERS_X;
    if (p.y + 1 < size.y && differs(p, p + ivec2(0, 1))) bits |= DIFFERS_Y;
    if (p.x + 1 < size.x && p.y + 1 < size.y && differs(p, p + ivec2(1, 1))) bits |= DIFFERS_XY;
    flags[p.y * pc.width + p.x] = bits;
}
