#version 460
// Interleaved deferred shading, step 2a: the G-buffer's position and normal into the padded layout's
// texel buffer (two vec4s per texel at pc.dst; padding and background: position.w = 0).
#include "interleaved/common.glsl"

void main() {
    uvec2 p = gl_GlobalInvocationID.xy;
    if (any(greaterThanEqual(p, uvec2(pc.padded_w, pc.padded_h)))) return;
    uint at = pc.dst + 2u * (p.y * pc.padded_w + p.x);
    bool inside = p.x < pc.width && p.y < pc.height;
    texels[at] = inside ? imageLoad(g_position, ivec2(p)) : vec4(0.0);
    texels[at + 1u] = inside ? imageLoad(g_normal, ivec2(p)) : vec4(0.0);
}
