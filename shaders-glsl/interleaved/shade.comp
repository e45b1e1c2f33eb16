#version 460
// Interleaved deferred shading, step 3: each texel of the split buffer (two vec4s at pc.src: position,
// w = 1 for a surface; normal) gathers its sub-buffer's subset of the VPLs — those whose index is the
// sub-buffer's k = j·n + i modulo n·m — scaled by n·m, without visibility (the paper's SNSM); one vec4
// per texel at pc.dst. The GLSL mirror of Tracer::gather_at (engine/src/reference/vpl.rs) with
// visibility off, as GBufferScene::gather calls it: the texel's position raised along its normal by
// SHADOW_RAY_OFFSET times its largest coordinate (at least 1).
#include "interleaved/common.glsl"

const float SHADOW_RAY_OFFSET = 1e-4;  // reference::SHADOW_RAY_OFFSET
const float PI = 3.14159265358979;

void main() {
    uvec2 p = gl_GlobalInvocationID.xy;
    if (any(greaterThanEqual(p, uvec2(pc.padded_w, pc.padded_h)))) return;
    uint at = p.y * pc.padded_w + p.x;
    vec4 position = texels[pc.src + 2u * at];
    vec3 normal = texels[pc.src + 2u * at + 1u].xyz;
    vec3 sum = vec3(0.0);
    if (position.w > 0.5) {
        uint k = (p.y / pc.sub_h) * pc.n + p.x / pc.sub_w;
        uint subsets = pc.n * pc.m;
        vec3 a = abs(position.xyz);
        float offset = SHADOW_RAY_OFFSET * max(max(max(a.x, a.y), a.z), 1.0);
        vec3 origin = position.xyz + offset * normal;
        for (uint i = k; i < pc.vpl_count; i += subsets) {
            vec3 d = vpls[i].position.xyz - origin;
            float d2 = dot(d, d);
            vec3 dir = d / sqrt(d2);
            float cx = dot(normal, dir), cy = -dot(vpls[i].normal.xyz, dir);
            bool lit = d2 > 0.0 && cx > 0.0 && cy > 0.0;
            sum += lit ? vpls[i].flux.rgb * (cx * cy / (PI * PI * max(d2, pc.clamp2))) : vec3(0.0);
        }
        sum *= float(subsets);
    }
    texels[pc.dst + at] = vec4(sum, 0.0);
}
