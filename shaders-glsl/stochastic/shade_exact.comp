#version 460
// The stochastic shading stage at the exact rates (engine/src/techniques/stochastic/shading/exact.rs):
// every hit shaded from its own sample (PER_SAMPLE), or once per (triangle, side) group of the pixel.
// The shading itself: stochastic/shade.glsl.
#include "stochastic/shade.glsl"
