#version 460
// Interleaved deferred shading, step 7: the direct light plus the albedo times the filtered indirect
// light (pc.src, one vec4 per texel in rows of pc.padded_w) on surfaces; the background keeps the direct
// pass' clear. Added with the pass' weight to the frame's result (cleared before the first pass).
#include "interleaved/common.glsl"

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(p, ivec2(pc.width, pc.height)))) return;
    vec3 c = imageLoad(g_direct, p).rgb;
    if (imageLoad(g_position, p).w > 0.5) {
        c += imageLoad(g_albedo, p).rgb * texels[pc.src + uint(p.y) * pc.padded_w + uint(p.x)].rgb;
    }
    imageStore(result, p, imageLoad(result, p) + pc.weight * vec4(c, 1.0));
}
