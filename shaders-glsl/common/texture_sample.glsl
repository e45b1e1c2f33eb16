// The reference's texture lookups (engine/src/scene/texture.rs: Texture::sample_bilinear and
// sample_alpha_bilinear): bilinear at the base level, repeat addressing, of the object's albedo
// texture (set 1). Visibility first means every sample is looked up at its own point and the S samples
// of the pixel do the filtering; a mip level from the sample footprint would blur against the ground
// truth.
#ifndef SHUTTER_TEXTURE_SAMPLE_GLSL
#define SHUTTER_TEXTURE_SAMPLE_GLSL
#include "common/object.glsl"

// The four texels (top-left, top-right, bottom-left, bottom-right) and the weights at uv.
void texture_footprint(vec2 uv, out ivec2 t00, out ivec2 t11, out vec2 f) {
    ivec2 size = textureSize(albedo_texture, 0);
    vec2 p = uv * vec2(size) - 0.5;
    vec2 p0 = floor(p);
    f = p - p0;
    ivec2 i0 = ivec2(p0);
    t00 = ivec2(mod(vec2(i0), vec2(size)));
    t11 = ivec2(mod(vec2(i0 + 1), vec2(size)));
}

vec3 texture_bilinear(vec2 uv) {
    ivec2 t00, t11;
    vec2 f;
    texture_footprint(uv, t00, t11, f);
    vec3 a = texelFetch(albedo_texture, ivec2(t00.x, t00.y), 0).rgb;
    vec3 b = texelFetch(albedo_texture, ivec2(t11.x, t00.y), 0).rgb;
    vec3 c = texelFetch(albedo_texture, ivec2(t00.x, t11.y), 0).rgb;
    vec3 d = texelFetch(albedo_texture, ivec2(t11.x, t11.y), 0).rgb;
    return mix(mix(a, b, f.x), mix(c, d, f.x), f.y);
}

// The alpha channel (linear), with the reference's operations in its order: a + (b - a) * f.
float texture_alpha_bilinear(vec2 uv) {
    ivec2 t00, t11;
    vec2 f;
    texture_footprint(uv, t00, t11, f);
    float a = texelFetch(albedo_texture, ivec2(t00.x, t00.y), 0).a;
    float b = texelFetch(albedo_texture, ivec2(t11.x, t00.y), 0).a;
    float c = texelFetch(albedo_texture, ivec2(t00.x, t11.y), 0).a;
    float d = texelFetch(albedo_texture, ivec2(t11.x, t11.y), 0).a;
    float top = a + (b - a) * f.x;
    float bottom = c + (d - c) * f.x;
    return top + (bottom - top) * f.y;
}

#endif
