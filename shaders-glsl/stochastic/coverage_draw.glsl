// What the two coverage stages share (the visibility buffer's, stochastic.frag, and the mask path's,
// mask.frag): the sample tile and the counters of set 3, a draw's moving triangle and the 5D inside test
// of one sample of the pixel against it, and stochastic transparency's coverage decisions. Both test the
// very same samples with the very same arithmetic, so both find the same hits.
// Needs the push constants (stochastic/visibility_push.glsl), the camera-space triangles
// (stochastic/camera_triangles.glsl), the inside test and texture alpha included first.
#ifndef SHUTTER_COVERAGE_DRAW_GLSL
#define SHUTTER_COVERAGE_DRAW_GLSL

#include "stochastic/sample_tile.glsl"

// The index in the sample tile of pixel `pix`'s first sample of this pass.
uint tile_base(uvec2 pix) {
    return ((pix.y % SAMPLE_TILE_SIZE) * SAMPLE_TILE_SIZE + pix.x % SAMPLE_TILE_SIZE) * pc.spp
         + pc.pass_index * pc.per_pass;
}

// Triangle `prim` of the draw over key segment `seg`: its camera-space vertices at the segment's ends
// (at pc.t0 for an object drawn without motion) and, with motion, the times its samples lie in.
struct DrawnTriangle {
    vec3 p_open[3];
    vec3 p_close[3];
    // The segment's key times (frame.glsl's ObjectView::time) and its samples' times [t_a, t_b) (the
    // first segment from -inf, the last to +inf).
    vec4 seg_time;
    float t_a;
    float t_b;
};

DrawnTriangle drawn_triangle(uint prim, uint seg) {
    DrawnTriangle d;
    load_triangle(prim, seg, pc.segment_count + 1u, d.p_open, d.p_close);
#ifdef NO_MOTION
    for (uint k = 0u; k < 3u; k++) d.p_open[k] = shutter_lerp(d.p_open[k], d.p_close[k], pc.t0);
    d.seg_time = vec4(0.0);
    d.t_a = 0.0;
    d.t_b = 0.0;
#else
    d.seg_time = object_views[pc.segment_first + seg].time;
    const float INF = uintBitsToFloat(0x7f800000u);
    d.t_a = seg == 0u ? -INF : d.seg_time.x;
    d.t_b = seg + 1u == pc.segment_count ? INF : d.seg_time.y;
#endif
    return d;
}

// Does sample i of this pass (tile index base + i) of pixel `pix` see triangle d — the 5D inside test
// of its ray at its time, its time inside the draw's segment, not the back of a one-sided object? Its
// view depth, barycentrics and side when it does.
bool drawn_sample_hit(DrawnTriangle d, uvec2 pix, uint base, uint i, out float z, out vec3 w, out bool back) {
    vec4 xl = sample_xy_lens[base + i];
#ifdef NO_DEFOCUS
    xl.zw = vec2(0.0);
#endif
    vec3 ro, rd;
    primary_ray(vec2(pix) + xl.xy, xl.zw, ro, rd);
#ifdef NO_MOTION
    bool in_segment = true;
    vec3 a = d.p_open[0], b = d.p_open[1], c = d.p_open[2];
#else
    float t = sample_time[base + i];
    bool in_segment = t >= d.t_a && t < d.t_b;
    float s = min((t - d.seg_time.x) * d.seg_time.z, 1.0);  // segment_time (common/frame.glsl)
    vec3 a = shutter_lerp(d.p_open[0], d.p_close[0], s);
    vec3 b = shutter_lerp(d.p_open[1], d.p_close[1], s);
    vec3 c = shutter_lerp(d.p_open[2], d.p_close[2], s);
#endif
    return sample_hit(a, b, c, ro, rd, z, w, back) && in_segment && !(back && pc.one_sided != 0u);
}

// Stochastic transparency: the reference's coverage decisions (common/coverage.glsl) for triangle `tri`
// (the frame's numbering, the reference's) in this pixel — its key and covered count, drawn once per
// (pixel, triangle) — so a partly covering surface hides exactly the samples it hides there. Opaque
// objects skip the hashes (a uniform branch: pc.alpha is the draw's).
struct Coverage {
    uint key;
    uint count;
};

Coverage triangle_coverage(uvec2 pix, uint tri) {
    Coverage c = Coverage(0u, 0u);
    if (pc.alpha < 1.0 || pc.alpha_from_texture != 0u) {
        c.key = coverage_key(pc.coverage_seed, pix, tri);
        c.count = coverage_count(pc.alpha, pc.spp, c.key);
    }
    return c;
}

// Does that triangle cover sample i of this pass, hit at barycentrics w? With texture alpha the
// coverage is the hit's (the reference's Tracer::coverage: alpha × the texture's alpha at the hit's
// uv), so the count is drawn for it; the rank is the triangle's in this pixel either way.
bool sample_covered(Coverage c, uint i, uint prim, vec3 w) {
    if (pc.alpha_from_texture != 0u) {
        vec2 uv = vec2(0.0);
        vec2 uvs[3];
        for (uint k = 0u; k < 3u; k++) {
            Vertex v = vertices[indices[3u * prim + k]];
            uvs[k] = vec2(v.uv[0], v.uv[1]);
        }
        uv = w.x * uvs[0] + w.y * uvs[1] + w.z * uvs[2];
        float alpha = pc.alpha * texture_alpha_bilinear(uv);
        uint count = coverage_count(alpha, pc.spp, c.key);
        return coverage_rank(pc.pass_index * pc.per_pass + i, pc.spp, c.key) < count;
    }
    return pc.alpha >= 1.0 || coverage_rank(pc.pass_index * pc.per_pass + i, pc.spp, c.key) < c.count;
}

#endif
