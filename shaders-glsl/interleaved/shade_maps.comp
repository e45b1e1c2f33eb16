#version 460
// Interleaved deferred shading, step 3, with the VPL shadow maps (the paper's SSM): interleaved/shade_body.glsl.
#define VPL_SHADOW_MAPS
#include "interleaved/shade_body.glsl"
