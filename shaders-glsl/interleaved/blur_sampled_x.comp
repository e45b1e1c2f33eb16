#version 460
// Interleaved deferred shading, step 6 along x with hardware-filtered pairs: interleaved/blur_sampled.glsl.
#define AXIS 0u
#define BLUR_SOURCE blur_x_source
#define STORE(p, v) imageStore(blur_mid, ivec2(p), vec4(v, 0.0))
#include "interleaved/blur_sampled.glsl"
