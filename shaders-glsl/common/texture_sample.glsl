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

// The four texels of the lookup at uv (top-left, top-right, bottom-left, bottom-right) and the weights.
void texture_texels(vec2 uv, out vec4 t[4], out vec2 f) {
    ivec2 t00, t11;
    texture_footprint(uv, t00, t11, f);
    t[0] = texelFetch(albedo_texture, ivec2(t00.x, t00.y), 0);
    t[1] = texelFetch(albedo_texture, ivec2(t11.x, t00.y), 0);
    t[2] = texelFetch(albedo_texture, ivec2(t00.x, t11.y), 0);
    t[3] = texelFetch(albedo_texture, ivec2(t11.x, t11.y), 0);
}

vec3 texture_bilinear(vec2 uv) {
    vec4 t[4];
    vec2 f;
    texture_texels(uv, t, f);
    return mix(mix(t[0].rgb, t[1].rgb, f.x), mix(t[2].rgb, t[3].rgb, f.x), f.y);
}

// The alpha channel (linear), with the reference's operations in its order: a + (b - a) * f.
float texture_alpha_bilinear(vec2 uv) {
    vec4 t[4];
    vec2 f;
    texture_texels(uv, t, f);
    float top = t[0].a + (t[1].a - t[0].a) * f.x;
    float bottom = t[2].a + (t[3].a - t[2].a) * f.x;
    return top + (bottom - top) * f.y;
}

#endif
