// Shadow-map lookups for a surface that receives shadows (SHADOWS defined): the GLSL side of
// engine/src/shadows.rs (the math, mirrored there and tested) and engine/src/techniques/shadow_maps.rs
// (what is bound). Every shadow-casting light has one lookup space (its view, or for a point light its
// position with the world's axes) and one or six rendered views (a point light's cube faces), each a
// tile of S depth samples per texel in one atlas: `sub_maps` tiles side by side of `msaa` samples each
// (SHADOW_MSAA: a multisampled atlas). With SHADOW_COLOR a second atlas holds, per sample, the product
// of the hues of the tinted surfaces in front of the stored depth and, in alpha, the depth of the
// nearest of them (docs/SHADOWS.md).
//
// Before calling shade(), the fragment stage sets `shadow_receiver` (object-space position and normal,
// key segment and time within it); shade() multiplies each shadowed light by shadow_light().
#ifndef SHUTTER_SHADOW_GLSL
#define SHUTTER_SHADOW_GLSL
#include "common/frame.glsl"

// The forward pipelines bind the shadow maps as set 3 (their technique set; sets 2 is empty); a
// stage whose sets 2 and 3 are its technique's defines SHADOW_SET 4 first (gpu/layout.rs
// SHADOW_SET_INDEX). Lavapipe (Mesa 22.3) crashes building a pipeline whose layout has two empty
// sets in a row, so the forward pipelines do not use set 4.
#ifndef SHADOW_SET
#define SHADOW_SET 3
#endif

struct ShadowView {
    mat4 base_to_face;  // the light's lookup space -> this view's space (identity but for cube faces)
    vec4 projection;    // kind (PROJECTION_*), half extent x (orthographic) or pixel scale, half extent y, size
    vec4 depth;         // near, far, atlas x and y of the first sub-map's tile (texels)
};

struct ShadowHeader {
    uvec4 counts;  // samples per texel S, MSAA per sub-map, sub-maps, PCF radius (texels)
    uvec4 spaces;  // ObjectView records per lookup space, unused x3
    vec4 bias;     // normal offset and depth bias (texels at the receiver), unused x2
    uvec4 lights[MAX_LIGHTS];  // per light: has a map, first view, view count (1 or 6), lookup space
};

#ifdef SHADOW_MSAA
layout(set = SHADOW_SET, binding = 0) uniform sampler2DMS shadow_depth;
#ifdef SHADOW_COLOR
layout(set = SHADOW_SET, binding = 1) uniform sampler2DMS shadow_color;
#endif
#else
layout(set = SHADOW_SET, binding = 0) uniform sampler2D shadow_depth;
#ifdef SHADOW_COLOR
layout(set = SHADOW_SET, binding = 1) uniform sampler2D shadow_color;
#endif
#endif
layout(set = SHADOW_SET, binding = 2, std430) readonly buffer ShadowInfo {
    ShadowHeader shadow;
    ShadowView shadow_views[];
};
layout(set = SHADOW_SET, binding = 3, std430) readonly buffer ShadowObjectViews { ObjectView shadow_object_views[]; };

struct ShadowReceiver {
    vec3 position;  // object space
    vec3 normal;    // object space (unnormalised)
    uint segment;   // key segment (ObjectView index within a view's records)
    float segment_time;
};
ShadowReceiver shadow_receiver;

// The cube face seeing direction d from a point light (shadows::cube_face_of): the largest coordinate
// in absolute value, ties to the earlier axis; faces +X, -X, +Y, -Y, +Z, -Z.
uint cube_face_of(vec3 d) {
    vec3 a = abs(d);
    if (a.x >= a.y && a.x >= a.z) return d.x >= 0.0 ? 0u : 1u;
    if (a.y >= a.z) return d.y >= 0.0 ? 2u : 3u;
    return d.z >= 0.0 ? 4u : 5u;
}

// View depth (distance along -Z) of a stored reversed-Z depth in view v (shadows::linear_depth).
float shadow_linear_depth(ShadowView v, float d) {
    float n = v.depth.x, f = v.depth.y;
    if (v.projection.x == PROJECTION_ORTHOGRAPHIC) return f - d * (f - n);
    return n * f / (d * (f - n) + n);
}

// The light's transmittance (rgb) to the receiver set in shadow_receiver, for light `i` (1 without a
// map): the fraction of the S depth samples of the (2r+1)^2 texels around the receiver's texel that
// lie no nearer the light than the receiver, each sample weighted by its hue product when the
// receiver lies behind that sample's nearest tinted surface (SHADOW_COLOR).
vec3 shadow_light(int i) {
    uvec4 l = shadow.lights[i];
    if (l.x == 0u) return vec3(1.0);
    ShadowReceiver r = shadow_receiver;
    ObjectView o = shadow_object_views[l.w * shadow.spaces.x + r.segment];
    vec3 p0 = (o.model_view[0] * vec4(r.position, 1.0)).xyz;
    vec3 p1 = (o.model_view[1] * vec4(r.position, 1.0)).xyz;
    vec3 p = p0 + (p1 - p0) * r.segment_time;  // as forward.vert moves the casters
    vec3 n = mix(mat3(o.normal_matrix[0]) * r.normal, mat3(o.normal_matrix[1]) * r.normal, r.segment_time);
    uint face = l.y;
    if (l.z == 6u) face += cube_face_of(p);
    ShadowView v = shadow_views[face];
    vec3 q = (v.base_to_face * vec4(p, 1.0)).xyz;
    vec3 nq = mat3(v.base_to_face) * n;
    bool ortho = v.projection.x == PROJECTION_ORTHOGRAPHIC;
    float size = v.projection.w;
    // Towards the light: +Z of an orthographic view, the origin of a perspective one.
    vec3 to_light = ortho ? vec3(0.0, 0.0, 1.0) : -q;
    float nl = length(nq);
    nq = nl > 0.0 ? nq / nl : vec3(0.0);
    if (dot(nq, to_light) < 0.0) nq = -nq;
    float z = -q.z;
    // One texel's width at the receiver, in view units.
    float texel = ortho ? 2.0 * v.projection.y / size : z / v.projection.y;
    int radius = int(shadow.counts.w);
    // Normal offset: far enough that every tap of the filter sees the receiver's own plane behind it.
    q += nq * (shadow.bias.x * float(radius + 1) * texel);
    z = -q.z;
    vec2 pixel;
    if (ortho) {
        pixel = vec2(0.5 * size * (1.0 + q.x / v.projection.y), 0.5 * size * (1.0 - q.y / v.projection.z));
    } else {
        float s = v.projection.y;
        pixel = vec2(0.5 * size + s * q.x / z, 0.5 * size - s * q.y / z);
    }
    float z_lit = z - shadow.bias.y * texel;
    ivec2 centre = ivec2(floor(pixel));
    int last = int(size) - 1;
    uint msaa = shadow.counts.y, sub_maps = shadow.counts.z;
    vec3 sum = vec3(0.0);
    float taps = 0.0;
    for (int dy = -radius; dy <= radius; ++dy) {
        for (int dx = -radius; dx <= radius; ++dx) {
            ivec2 t = clamp(centre + ivec2(dx, dy), ivec2(0), ivec2(last));
            for (uint m = 0u; m < sub_maps; ++m) {
                ivec2 at = ivec2(v.depth.zw) + ivec2(int(m) * int(size), 0) + t;
                for (uint k = 0u; k < msaa; ++k) {
#ifdef SHADOW_MSAA
                    float d = texelFetch(shadow_depth, at, int(k)).r;
#else
                    float d = texelFetch(shadow_depth, at, 0).r;
#endif
                    taps += 1.0;
                    if (shadow_linear_depth(v, d) < z_lit) continue;  // an occluder nearer the light
#ifdef SHADOW_COLOR
#ifdef SHADOW_MSAA
                    vec4 c = texelFetch(shadow_color, at, int(k));
#else
                    vec4 c = texelFetch(shadow_color, at, 0);
#endif
                    // Alpha: the nearest tinted surface's depth (0: none in front of the sample).
                    bool behind_tint = c.a > 0.0 && shadow_linear_depth(v, c.a) < z_lit;
                    sum += behind_tint ? c.rgb : vec3(1.0);
#else
                    sum += vec3(1.0);
#endif
                }
            }
        }
    }
    return sum / max(taps, 1.0);
}

#endif
