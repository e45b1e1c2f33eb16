#ifndef SHUTTER_INTERLEAVED_SHADE_GLSL
#define SHUTTER_INTERLEAVED_SHADE_GLSL
#include "interleaved/common.glsl"
// Interleaved deferred shading, step 3 (the body of shade.comp, and of shade_maps.comp with
// VPL_SHADOW_MAPS): each texel of the split buffer (two vec4s at pc.src: position,
// w = 1 for a surface; normal) gathers its sub-buffer's subset of the VPLs — those whose index is the
// sub-buffer's k = j·n + i modulo n·m — scaled by n·m, without visibility (the paper's SNSM); one vec4
// per texel at pc.dst. The GLSL mirror of Tracer::gather_at (engine/src/reference/vpl.rs) with
// visibility off, as GBufferScene::gather calls it: the texel's position raised along its normal by
// SHADOW_RAY_OFFSET times its largest coordinate (at least 1). With VPL_SHADOW_MAPS each VPL's light
// is kept only where its shadow map sees the texel (the paper's SSM; the mirror traces exact shadow
// rays instead) — a file of its own rather than a branch on a push constant, which llvmpipe paid in
// every iteration of the loop (18 % of the shading at 8×6).

const float SHADOW_RAY_OFFSET = 1e-4;  // reference::SHADOW_RAY_OFFSET
const float PI = 3.14159265358979;

// Whether VPL i (of the pass' set) shadow map sees the point p at distance `dist` from it in direction d: the cube face of
// d's major axis (+x, −x, +y, −y, +z, −z), the texel p projects to, its stored distance with the bias.
bool vpl_sees(uint i, vec3 p, vec3 d, float dist) {
    vec3 a = abs(d);
    uint f = a.x >= a.y && a.x >= a.z ? (d.x > 0.0 ? 0u : 1u) : (a.y >= a.z ? (d.y > 0.0 ? 2u : 3u) : (d.z > 0.0 ? 4u : 5u));
    // The atlas holds the pass' set (face 6 i + f); the matrices every set's, from the set's first.
    uint face = 6u * i + f;
    vec4 clip = vpl_faces[6u * pc.vpl_first + face] * vec4(p, 1.0);
    vec2 ndc = clip.xy / clip.w;
    ivec2 t = clamp(ivec2((ndc * 0.5 + 0.5) * float(pc.face_size)), ivec2(0), ivec2(int(pc.face_size) - 1));
    ivec2 origin = ivec2(int(face % pc.atlas_cols), int(face / pc.atlas_cols)) * int(pc.face_size);
    float stored = texelFetch(vpl_maps, origin + t, 0).r * pc.far;
    return dist <= stored * (1.0 + pc.shadow_bias) + pc.shadow_bias;
}

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
            Vpl v = vpls[pc.vpl_first + i];
            vec3 d = v.position.xyz - origin;
            float d2 = dot(d, d);
            vec3 dir = d / sqrt(d2);
            float cx = dot(normal, dir), cy = -dot(v.normal.xyz, dir);
            bool lit = d2 > 0.0 && cx > 0.0 && cy > 0.0;
#ifdef VPL_SHADOW_MAPS
            lit = lit && vpl_sees(i, origin, -d, sqrt(d2));
#endif
            sum += lit ? v.flux.rgb * (cx * cy / (PI * PI * max(d2, pc.clamp2))) : vec3(0.0);
        }
        sum *= float(subsets);
    }
    texels[pc.dst + at] = vec4(sum, 0.0);
}
#endif
