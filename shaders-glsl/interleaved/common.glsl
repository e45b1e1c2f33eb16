// Interleaved deferred shading's compute passes (engine/src/techniques/interleaved.rs): set 3 and the
// push constants every pass shares, and the split layout's index maps — the GLSL mirror of
// engine/src/mirror/interleaved.rs (Layout::split, block_split, block_translate), operation for operation.
#ifndef SHUTTER_INTERLEAVED_GLSL
#define SHUTTER_INTERLEAVED_GLSL

layout(local_size_x = 8, local_size_y = 8) in;

// Every texel buffer of the frame in one: regions of vec4s at the offsets the passes are given.
layout(set = 3, binding = 0, std430) buffer Texels { vec4 texels[]; };
struct Vpl {
    vec4 position;  // camera space; w unused
    vec4 normal;
    vec4 flux;
};
layout(set = 3, binding = 1, std430) readonly buffer Vpls { Vpl vpls[]; };
// The discontinuity buffer: DIFFERS_X | DIFFERS_Y | DIFFERS_XY bits per texel of the image.
layout(set = 3, binding = 2, std430) buffer Flags { uint flags[]; };
layout(set = 3, binding = 3, rgba32f) uniform readonly image2D g_position;
layout(set = 3, binding = 4, rgba32f) uniform readonly image2D g_normal;
layout(set = 3, binding = 5, rgba32f) uniform readonly image2D g_albedo;
layout(set = 3, binding = 6, rgba32f) uniform readonly image2D g_direct;
layout(set = 3, binding = 7, rgba32f) uniform image2D result;
// The VPL shadow maps (SSM): an atlas of cube faces of the pass' VPL set, face f of its VPL i at index 6 i + f in rows of
// pc.atlas_cols faces of pc.face_size² texels, each texel the distance from the VPL over pc.far; and
// each face's camera-space view-projection, every set's (the pass' set from 6 vpl_first).
layout(set = 3, binding = 8) uniform sampler2D vpl_maps;
layout(set = 3, binding = 9, std430) readonly buffer VplFaces { mat4 vpl_faces[]; };
// The blur with hardware-filtered pairs (blur_sampled.glsl): the gathered light copied into an image,
// and the x pass' result, each read through a linear sampler with unnormalized coordinates.
layout(set = 3, binding = 10) uniform sampler2D blur_x_source;
layout(set = 3, binding = 11) uniform sampler2D blur_y_source;
layout(set = 3, binding = 12, rgba32f) uniform writeonly image2D blur_mid;

layout(push_constant) uniform Push {
    uint width;        // the image
    uint height;
    uint padded_w;     // the layout (Layout::width, height): whole blocks
    uint padded_h;
    uint n;            // the pattern
    uint m;
    uint block_w;      // the two-pass split's block, texels
    uint block_h;
    uint sub_w;        // one sub-buffer
    uint sub_h;
    uint src;          // offsets into texels[], vec4s
    uint dst;
    uint stride;       // vec4s per texel of a permutation
    uint map;          // MAP_* (permute.comp)
    uint pull;         // 1: dst[p] = src[map(p)]; 0: dst[map(p)] = src[p]
    uint vpl_first;    // the pass' VPL set: vpls[vpl_first ..][.. vpl_count]
    uint vpl_count;
    float clamp2;      // the VPLs' clamping distance, squared
    uint radius;       // the blur
    uint axis;         // 0: along x, 1: along y
    uint edges;        // EDGES_* (blur.comp)
    uint bilinear;
    float normal_cos;  // the discontinuity thresholds
    float position_rel;
    uint face_size;    // the VPL shadow maps (0: none, SNSM)
    uint atlas_cols;
    float far;
    float shadow_bias; // a receiver is lit when its distance ≤ the map's · (1 + bias) + bias
    float weight;      // the pass' share of the frame (compose.comp): 1 / passes
} pc;

const uint MAP_SPLIT = 0u;
const uint MAP_BLOCK_SPLIT = 1u;
const uint MAP_BLOCK_TRANSLATE = 2u;

const uint DIFFERS_X = 1u;
const uint DIFFERS_Y = 2u;
const uint DIFFERS_XY = 4u;

uvec2 split_of(uvec2 p) {
    return uvec2((p.x % pc.n) * pc.sub_w + p.x / pc.n, (p.y % pc.m) * pc.sub_h + p.y / pc.m);
}

uvec2 block_split_of(uvec2 p) {
    uvec2 l = uvec2(p.x % pc.block_w, p.y % pc.block_h);
    return uvec2(p.x - l.x + (l.x % pc.n) * (pc.block_w / pc.n) + l.x / pc.n,
                 p.y - l.y + (l.y % pc.m) * (pc.block_h / pc.m) + l.y / pc.m);
}

uvec2 block_translate_of(uvec2 p) {
    uvec2 s = uvec2(pc.block_w / pc.n, pc.block_h / pc.m);
    uvec2 b = uvec2(p.x / pc.block_w, p.y / pc.block_h);
    uvec2 l = uvec2(p.x % pc.block_w, p.y % pc.block_h);
    uvec2 ij = l / s;
    return uvec2(ij.x * pc.sub_w + b.x * s.x + l.x % s.x, ij.y * pc.sub_h + b.y * s.y + l.y % s.y);
}

#endif
