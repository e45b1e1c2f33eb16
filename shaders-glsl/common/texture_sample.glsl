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

// Texture-space shading's pre-filter (pass 1: an atlas texel stands for every sample that looks it up
// later, so it filters the texture over its own footprint). GLSL port of
// texture_space::filter::anisotropic_taps: trilinear taps of the mip chain along the major axis of
// the footprint spanned by the uv derivatives dx, dy. With alpha_weighted (a cut-out: coverage comes
// from the alpha), each tap's colour weighs by its alpha — the colour of the covered part, as the
// mips are built (vk::srgb_mip_chain).
const uint MAX_ANISOTROPIC_TAPS = 8u;
vec3 texture_prefiltered(vec2 uv, vec2 dx, vec2 dy, bool alpha_weighted) {
    vec2 size = vec2(textureSize(albedo_texture, 0));
    float lx = length(dx * size), ly = length(dy * size);
    vec2 major = lx >= ly ? dx : dy;
    float l_major = max(lx, ly), l_minor = min(lx, ly);
    float ratio = l_major / max(l_minor, 1e-6);
    uint count = clamp(uint(ceil(ratio)), 1u, MAX_ANISOTROPIC_TAPS);
    float width = max(l_major / float(count), l_minor);
    float lod = width > 1.0 ? log2(width) : 0.0;
    vec2 step = major / float(count);
    vec3 sum = vec3(0.0), weighted = vec3(0.0);
    float alpha = 0.0;
    for (uint i = 0u; i < count; i++) {
        vec4 c = textureLod(albedo_texture, uv + step * (float(i) + 0.5 - 0.5 * float(count)), lod);
        sum += c.rgb;
        weighted += c.rgb * c.a;
        alpha += c.a;
    }
    return alpha_weighted && alpha > 0.0 ? weighted / alpha : sum / float(count);
}

#endif
