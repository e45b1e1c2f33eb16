// Shadow-map lookups for a surface that receives shadows (SHADOWS defined): the GLSL side of
// engine/src/mirror/shadow_maps.rs (the math, mirrored there and tested) and engine/src/techniques/shadow_maps.rs
// (what is bound). Every shadow-casting light has one lookup space (its view, or for a point light its
// position with the world's axes) and one or six rendered views (a point light's cube faces), each a
// tile of S depth samples per texel in one atlas: `sub_maps` tiles side by side of `msaa` samples each
// (SHADOW_MSAA: a multisampled atlas). With SHADOW_COLOR a second atlas holds, per sample, the product
// of the hues of the tinted surfaces in front of the stored depth and, in alpha, the depth of the
// nearest of them (docs/SHADOWS.md).
//
// Before calling shade(), the fragment stage sets `shadow_receiver` (object-space position, shading
// normal and geometric normal, key segment and time within it); shade() multiplies each shadowed
// light by shadow_light(). A fragment stage finds the geometric normal with shadow_plane_normal().
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
    vec4 bias;     // depth slack (texels at the receiver), unused x3
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
    vec3 plane;     // the triangle's normal, object space (unnormalised; zero: unknown, use `normal`)
    uint segment;   // key segment (ObjectView index within a view's records)
    float segment_time;
};
ShadowReceiver shadow_receiver;

// The geometric normal of the triangle a fragment lies on, from the screen derivatives of its
// object-space position (every interpolated point of a triangle lies in its plane, helper lanes'
// too); zero where they are degenerate (a triangle seen edge-on), which shadow_light() reads as
// "use the shading normal". Fragment stages only.
#define shadow_plane_normal(p) cross(dFdx(p), dFdy(p))

// The cube face seeing direction d from a point light (shadows::cube_face_of): the largest coordinate
// in absolute value, ties to the earlier axis; faces +X, -X, +Y, -Y, +Z, -Z.
uint cube_face_of(vec3 d) {
    vec3 a = abs(d);
    if (a.x >= a.y && a.x >= a.z) return d.x >= 0.0 ? 0u : 1u;
    if (a.y >= a.z) return d.y >= 0.0 ? 2u : 3u;
    return d.z >= 0.0 ? 4u : 5u;
}

// Below this cosine between a receiver's plane and the light's rays the plane counts as parallel to
// them (shadows::MIN_PLANE_COS).
const float SHADOW_MIN_PLANE_COS = 1e-4;

// Where the rasterizer takes sample k of `msaa` within a texel: the standard sample locations for 1,
// 2, 4 and 8 samples, the centre otherwise (shadows::sample_position).
vec2 shadow_sample_position(uint msaa, uint k) {
    if (msaa == 2u) return k == 0u ? vec2(0.75) : vec2(0.25);
    if (msaa == 4u) {
        const vec2 four[4] = vec2[4](vec2(0.375, 0.125), vec2(0.875, 0.375), vec2(0.125, 0.625), vec2(0.625, 0.875));
        return four[k & 3u];
    }
    if (msaa == 8u) {
        const vec2 eight[8] = vec2[8](vec2(0.5625, 0.3125), vec2(0.4375, 0.6875), vec2(0.8125, 0.5625),
                                      vec2(0.3125, 0.1875), vec2(0.1875, 0.8125), vec2(0.0625, 0.4375),
                                      vec2(0.6875, 0.9375), vec2(0.9375, 0.0625));
        return eight[k & 7u];
    }
    return vec2(0.5);
}

// The light's transmittance (rgb) to the receiver set in shadow_receiver, for light `i` (1 without a
// map) (shadows::FaceProjection::lookup): over the taps of a box of 2r + 1 texels a side centred on
// the receiver's map position (the map read as constant per texel: (2r + 2)^2 taps, the outer ones
// weighted by their overlap), the weighted fraction of depth samples that lie no nearer the light
// than the receiver's own plane at that sample's position (than the receiver itself where the plane
// recedes beyond it: a surface behind the receiver never shadows it), less the slack; each such
// sample weighted by its hue product when the receiver lies behind that sample's nearest tinted
// surface (SHADOW_COLOR). The comparisons are in stored (reversed-Z) depth, in which a plane is
// affine in the map position (shadows::FaceProjection::stored_plane).
vec3 shadow_light(int i) {
    uvec4 l = shadow.lights[i];
    if (l.x == 0u) return vec3(1.0);
    ShadowReceiver r = shadow_receiver;
    ObjectView o = shadow_object_views[l.w * shadow.spaces.x + r.segment];
    vec3 p0 = (o.model_view[0] * vec4(r.position, 1.0)).xyz;
    vec3 p1 = (o.model_view[1] * vec4(r.position, 1.0)).xyz;
    vec3 p = p0 + (p1 - p0) * r.segment_time;  // as forward.vert moves the casters
    vec3 plane = dot(r.plane, r.plane) > 0.0 ? r.plane : r.normal;
    vec3 n = mix(mat3(o.normal_matrix[0]) * plane, mat3(o.normal_matrix[1]) * plane, r.segment_time);
    uint face = l.y;
    if (l.z == 6u) face += cube_face_of(p);
    ShadowView v = shadow_views[face];
    vec3 q = (v.base_to_face * vec4(p, 1.0)).xyz;
    vec3 m = mat3(v.base_to_face) * n;
    bool ortho = v.projection.x == PROJECTION_ORTHOGRAPHIC;
    float size = v.projection.w;
    float near = v.depth.x, far = v.depth.y;
    // The plane's normal, facing the light (+Z of an orthographic view, the origin of a perspective
    // one); none known: the plane facing the light.
    vec3 to_light = ortho ? vec3(0.0, 0.0, 1.0) : -q;
    float ml = length(m);
    m = ml > 0.0 ? m / ml : normalize(to_light);
    if (dot(m, to_light) < 0.0) m = -m;
    float z = -q.z;
    vec2 pixel;
    // The receiver's stored depth, the plane's gradient in stored depth per texel, and one view
    // unit in stored depth at the receiver.
    float d_q;
    vec2 gradient;
    float per_view;
    if (ortho) {
        pixel = vec2(0.5 * size * (1.0 + q.x / v.projection.y), 0.5 * size * (1.0 - q.y / v.projection.z));
        d_q = (far - z) / (far - near);
        gradient = vec2(-m.x * 2.0 * v.projection.y / size, m.y * 2.0 * v.projection.z / size)
                 / (max(m.z, SHADOW_MIN_PLANE_COS) * (far - near));
        per_view = 1.0 / (far - near);
    } else {
        float s = v.projection.y;
        pixel = vec2(0.5 * size + s * q.x / z, 0.5 * size - s * q.y / z);
        d_q = near * (far - z) / ((far - near) * z);
        float mq = min(dot(m, q), -SHADOW_MIN_PLANE_COS * length(q));
        gradient = vec2(m.x, -m.y) * (near * far / ((far - near) * s * mq));
        per_view = near * far / ((far - near) * z * z);
    }
    // One texel's width at the receiver, in view units: the slack's unit.
    float texel = ortho ? 2.0 * v.projection.y / size : z / v.projection.y;
    float slack = shadow.bias.x * texel * per_view;
    int radius = int(shadow.counts.w);
    int n_taps = 2 * radius + 2;
    vec2 lo = pixel - vec2(float(radius) + 0.5);
    vec2 first = floor(lo);
    vec2 f = lo - first;
    ivec2 base = ivec2(first);
    int last = int(size) - 1;
    uint msaa = shadow.counts.y, sub_maps = shadow.counts.z;
    vec3 sum = vec3(0.0);
    float total = 0.0;
    for (uint k = 0u; k < msaa; ++k) {
        // The plane at this sample's location in the first tap, then one texel on per tap.
        vec2 first_at = first + shadow_sample_position(msaa, k) - pixel;
        for (int dy = 0; dy < n_taps; ++dy) {
            float wy = dy == 0 ? 1.0 - f.y : (dy == n_taps - 1 ? f.y : 1.0);
            if (wy <= 0.0) continue;
            for (int dx = 0; dx < n_taps; ++dx) {
                float w = wy * (dx == 0 ? 1.0 - f.x : (dx == n_taps - 1 ? f.x : 1.0));
                if (w <= 0.0) continue;
                ivec2 t = clamp(base + ivec2(dx, dy), ivec2(0), ivec2(last));
                vec2 at = vec2(t - base) + first_at;
                // Reversed Z: a sample shadows when it is nearer (larger) than the receiver's plane
                // there (its own depth where the plane recedes beyond it) plus the slack.
                float bound = max(d_q + dot(gradient, at), d_q) + slack;
#ifdef SHADOW_COLOR
                // The hue pass writes the tinted surface's depth of the texel's centre
                // (gl_FragCoord.z without sample shading), so that is where it is compared.
                float tint_bound = max(d_q + dot(gradient, vec2(t - base) + first + 0.5 - pixel), d_q) + slack;
#endif
                for (uint sm = 0u; sm < sub_maps; ++sm) {
                    ivec2 at_texel = ivec2(v.depth.zw) + ivec2(int(sm) * int(size), 0) + t;
#ifdef SHADOW_MSAA
                    float d = texelFetch(shadow_depth, at_texel, int(k)).r;
#else
                    float d = texelFetch(shadow_depth, at_texel, 0).r;
#endif
                    total += w;
                    if (d > bound) continue;  // an occluder nearer the light (0, the clear, never is)
#ifdef SHADOW_COLOR
#ifdef SHADOW_MSAA
                    vec4 c = texelFetch(shadow_color, at_texel, int(k));
#else
                    vec4 c = texelFetch(shadow_color, at_texel, 0);
#endif
                    // Alpha: the nearest tinted surface's depth (0: none in front of the sample).
                    bool behind_tint = c.a > 0.0 && c.a > tint_bound;
                    sum += w * (behind_tint ? c.rgb : vec3(1.0));
#else
                    sum += vec3(w);
#endif
                }
            }
        }
    }
    return sum / max(total, 1e-6);
}

#endif
