#version 460
// Interleaved deferred shading, step 6 along y with hardware-filtered pairs: interleaved/blur_sampled.glsl.
#define AXIS 1u
#define BLUR_SOURCE blur_y_source
#define STORE(p, v) texels[pc.dst + (p).y * pc.padded_w + (p).x] = vec4(v, 0.0)
#include "interleaved/blur_sampled.glsl"
