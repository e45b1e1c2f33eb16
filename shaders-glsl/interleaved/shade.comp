#version 460
// Interleaved deferred shading, step 3, without VPL visibility (the paper's SNSM): interleaved/shade_body.glsl.
#include "interleaved/shade_body.glsl"
