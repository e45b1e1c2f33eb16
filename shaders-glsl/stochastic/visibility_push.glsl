// Push constants of the stochastic rasterizer's visibility core: its coverage and tint draws, shared by
// their vertex, geometry and fragment stages. Mirrors `VisibilityPush` in
// engine/src/techniques/stochastic/layout.rs; the shading stages push their own (shade_push.glsl).
#ifndef SHUTTER_STOCHASTIC_VISIBILITY_PUSH_GLSL
#define SHUTTER_STOCHASTIC_VISIBILITY_PUSH_GLSL

layout(push_constant) uniform Push {
    uint bound;       // bound kind id (BOUND_* in stochastic/bounds.glsl)
    uint pass_index;  // this pass tests samples [pass_index * per_pass, (pass_index + 1) * per_pass) of each pixel
    uint spp;         // S: samples per pixel over all passes (the sample tile's depth)
    uint per_pass;    // samples per pixel and pass (the visibility buffer's depth)
    float dilate;     // box half-size the bound is dilated by, pixels (bounds::dilation_px)
    // Interval bounds: this draw tests the pass' samples [sample_first, sample_first + sample_count)
    // that lie in key segment `segment` of the object's motion (samples come in time order), and
    // bounds the triangle over [t0, t1] of the segment's local time, which holds all of theirs.
    // NO_MOTION: t0 = t1 is the local time of mid-shutter in `segment`.
    uint sample_first;
    uint sample_count;
    float t0;
    float t1;
    // The object's first triangle in the frame's numbering (visibility payloads) and its count.
    uint triangle_base;
    uint triangle_count;
    // The object's motion: its first key segment in object_views and its segment count; this draw's
    // segment (0 .. segment_count).
    uint segment_first;
    uint segment_count;
    uint segment;
    // Cluster bounds (CLUSTER_BOUNDS): triangles per cluster.
    uint cluster_size;
    // Stochastic transparency: the object's coverage (1: opaque) and the coverage hashes' seed
    // (common/coverage.glsl).
    float alpha;
    uint coverage_seed;
    // 1: the coverage is alpha times the texture's alpha at each hit's uv (stochastic.frag).
    uint alpha_from_texture;
    // TINT_PASS (stochastic.frag): the object's tint as transparency::tint_log, −log2 T per channel
    // in 16.16 fixed point.
    uint tint_log_r;
    uint tint_log_g;
    uint tint_log_b;
    // 1: the object's material is one-sided (scene::Material::one_sided): stochastic.frag drops every
    // hit on a triangle's back, as the reference's camera rays skip it.
    uint one_sided;
} pc;

#endif
