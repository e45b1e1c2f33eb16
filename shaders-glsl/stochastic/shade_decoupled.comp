#version 460
// The stochastic shading stage of decoupled shading
// (engine/src/techniques/stochastic/shading/decoupled.rs, stochastic/decoupled.glsl): per sample, each
// hit's radiance from its key's memoization-cache entry, or (deferred) from its hash-table entry.
#define PER_SAMPLE
#define DECOUPLED
#include "stochastic/shade.glsl"
