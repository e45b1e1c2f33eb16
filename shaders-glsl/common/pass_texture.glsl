// The forward passes' texture lookups (techniques/forward.rs; the footprint is
// sampling::pass_texture_footprint): one of P jittered passes stands for 1/P of the pixel's area, so
// its texture filter spans 1/sqrt(P) of the pixel's side. The screen derivatives of uv scaled by that
// choose the mip level and anisotropy (textureGrad): 1 for a single pass (the hardware's own choice),
// and as P grows the filter shrinks towards level 0, which is what the reference integrates (bilinear
// at the base level, common/texture_sample.glsl). With the hardware's one-pixel footprint instead,
// accumulation converged to a blurrier image than the reference (issue 33).
//
// pass_texture_begin runs first in main(), before any discard: derivatives need the whole quad.
#ifndef SHUTTER_PASS_TEXTURE_GLSL
#define SHUTTER_PASS_TEXTURE_GLSL
#include "common/object.glsl"

vec2 pass_uv_dx = vec2(0.0), pass_uv_dy = vec2(0.0);
float pass_footprint = 1.0;

void pass_texture_begin(vec2 uv, float footprint) {
    pass_footprint = footprint;
    pass_uv_dx = dFdx(uv) * footprint;
    pass_uv_dy = dFdy(uv) * footprint;
}

// The albedo texture at uv over this pass' footprint. A footprint of 1 is the hardware's implicit
// lookup itself (a uniform branch): lavapipe's explicit-gradient path rounds the level differently,
// and one pass (`pinhole`) keeps the very pixels it had.
vec4 pass_texture(vec2 uv) {
    if (pass_footprint == 1.0) return texture(albedo_texture, uv);
    return textureGrad(albedo_texture, uv, pass_uv_dx, pass_uv_dy);
}

#endif
