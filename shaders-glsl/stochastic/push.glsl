// Push constants of the stochastic rasterizer, shared by its vertex, geometry and fragment stages.
// Mirrors `StochasticPush` in engine/src/techniques/stochastic.rs.
#ifndef SHUTTER_STOCHASTIC_PUSH_GLSL
#define SHUTTER_STOCHASTIC_PUSH_GLSL

layout(push_constant) uniform Push {
    uint object;      // index into `objects`
    uint bound;       // bound kind id (BOUND_* in stochastic/bounds.glsl)
    uint pass_index;  // this pass tests samples [pass_index * msaa, (pass_index + 1) * msaa) of each pixel
    uint spp;         // S: samples per pixel over all passes (the sample tile's depth)
    uint msaa;        // MSAA samples per pass
    float footprint;  // texture footprint of one sample, in pixels (1 / sqrt(S))
    float dilate;     // box half-size the bound is dilated by, pixels (bounds::dilation_px)
} pc;

#endif
