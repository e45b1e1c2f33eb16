// The stochastic frame's sample tile and counters (set 3, bindings 0-2), as every stage of it that
// reads them declares them: the coverage stages (stochastic/coverage_draw.glsl) and the shading
// stages (stochastic/shade.glsl). Mirrors `STOCHASTIC_SET` and the `COUNTERS` order in
// engine/src/techniques/stochastic/.
#ifndef SHUTTER_STOCHASTIC_SAMPLE_TILE_GLSL
#define SHUTTER_STOCHASTIC_SAMPLE_TILE_GLSL

// The sample tile (sampling::SampleTile): 64 x 64 pixels x S samples; xy in [0,1) within the pixel,
// lens already mapped to the aperture shape, time already warped by the shutter curve.
layout(set = 3, binding = 0, std430) readonly buffer SamplesXyLens { vec4 sample_xy_lens[]; };
layout(set = 3, binding = 1, std430) readonly buffer SamplesTime { float sample_time[]; };
layout(set = 3, binding = 2, std430) buffer Counters {
    uint samples_tested;
    uint samples_hit;
    uint shading_invocations;
    uint fragments;
    // Decoupled shading (shade_decoupled.comp): cache lookups, hits, evictions, stores lost to a race,
    // and (deferred) keys the hash table had no room for.
    uint cache_lookups;
    uint cache_hits;
    uint cache_evictions;
    uint cache_busy;
    uint cache_overflows;
} counters;

const uint SAMPLE_TILE_SIZE = 64u;

#endif
