#version 460
// The stochastic shading stage of adaptive texture-space shading, pass 2
// (engine/src/techniques/stochastic/shading/texture_space.rs): each hit looks its radiance up in its
// object's shading atlas, per sample (PER_SAMPLE) or once per group. Nothing is shaded here, so the
// shadow-map axes are pass 1's (texture_space/atlas.frag), not this file's.
#define TEXTURE_SPACE
#include "stochastic/shade.glsl"
