#version 460
// Pass 1 of adaptive texture-space shading, fragment stage: one texel of the shading atlas shaded at
// its surface point — at the lens centre and mid-shutter (view-independent as in the paper: the eye
// is the lens centre for every sample that later looks this texel up). Alpha marks which sub-pass
// wrote the texel: 1 the shade sub-pass, 0.5 the conservative one (tests read it; pass 2 ignores it).
// Material textures are pre-filtered over the texel's own footprint (common/texture_sample.glsl,
// texture_prefiltered: the uv derivatives across one atlas texel, anisotropic taps of the mip chain).
// A departure from the paper, whose pre-filter is the generalised Loviscach filter over
// (x, y, u, v, t) (texture_space::filter): here every sample looks the atlas up at its own lens point
// and time, so the samples integrate over the lens and the shutter themselves; filtering over them in
// the atlas too would blur twice. The texel footprint already grows with defocus (the level).
//   SHADOWS (SHADOW_MSAA, SHADOW_COLOR): lights attenuated by their shadow maps (set 4) at the
//     texel's surface point at mid-shutter, as the stochastic shading pass does per sample (the maps
//     are rendered once per frame: the stochastic frame takes only still casters).
//   INSTRUMENTED: counts the texels each sub-pass shades (set 3, binding 2). Depth is tested before
//     the fragment stage runs (early_fragment_tests: this stage neither discards nor writes depth),
//     so a hull texel behind an already shaded one is neither shaded nor counted.
//   Several shading times (pc.shading_times > 1, texture_space::rate::shading_time_count: the object
//     turns in camera space within the shutter). A departure from the paper, which shades at
//     mid-shutter: our vertices, normals and lights move linearly in camera space, so a turn shrinks
//     the object at mid-shutter and a half turn collapses it onto a line (its lerped normals and
//     light directions degenerate: N·L ≈ 1, not what any sample sees). The texel is shaded instead
//     at each shading time t_j, as the per-sample path shades a sample at its time (stochastic/
//     shade.glsl shade_at: the triangle, normal, lights and eye at t_j, the side facing the eye
//     then), and the shadings are averaged, each weighed by how many samples see the texel at t_j:
//     the density of its projection at the lens centre, pixels per unit of area (ts_sample_density)
//     — 0 where it is behind the camera, outside [near, far] or off the image (by its circle of
//     confusion) — so the texel holds the average of what the samples that see it would shade,
//     ignoring occlusion. Where it is seen at none of the times (a gutter texel past the image's
//     edge), the plain average over the times it is in front at, else over all.
// Sets 2 and 3 are this technique's: the shadow maps are set 4 (gpu/layout.rs SHADOW_SET_INDEX).
#define SHADOW_SET 4
#include "common/frame.glsl"
#include "common/object.glsl"
#include "common/shading.glsl"
#include "common/texture_sample.glsl"
#include "texture_space/atlas_push.glsl"
#include "texture_space/rate.glsl"

layout(location = 0) in vec3 g_position;
layout(location = 1) in vec3 g_normal;
layout(location = 2) in vec2 g_uv;
#ifdef SHADOWS
layout(location = 3) in vec3 g_object_position;
layout(location = 4) in vec3 g_object_normal;
#endif
layout(location = 5) in vec3 g_bary;
layout(location = 6) flat in uint g_prim;
layout(location = 0) out vec4 out_color;

layout(early_fragment_tests) in;

#ifdef INSTRUMENTED
layout(set = 3, binding = 2, std430) buffer AtlasCounters {
    uint shaded_texels;  // by the shade sub-pass
    uint gutter_texels;  // by the conservative sub-pass
} counters;
#endif

// Samples per unit of surface area seeing camera-space point `pos` of camera-space triangle `tri`
// at the lens centre, up to a constant factor: the projection's pixels per unit area,
// s²·|n̂·pos| / z³ (z = −pos.z), times the triangle's area (the texel's share of the surface changes
// with it) — |(e1 × e2)·v0| / z³, with the constant s²/2 left out. 0 behind the camera, outside
// [near, far] or off the image by more than its circle of confusion and a pixel.
float ts_sample_density(vec3 tri[3], vec3 pos) {
    float z = -pos.z;
    if (!(z >= view.lens.z && z <= view.lens.w)) return 0.0;
    vec2 q = ts_project(pos);
    float margin = abs(view.lens.x * view.viewport.z * (1.0 / view.lens.y - 1.0 / z)) + 1.0;
    if (any(lessThan(q, vec2(-margin))) || any(greaterThan(q, view.viewport.xy + margin))) return 0.0;
    float d = abs(dot(cross(tri[1] - tri[0], tri[2] - tri[0]), tri[0])) / (z * z * z);
    return isinf(d) || isnan(d) ? 0.0 : d;
}

#ifdef SHADOWS
// The shadow lookup's receiver plane (common/shadow.glsl), set at the top of main().
vec3 ts_plane_normal;
#endif

// The texel's surface point at shutter time t: camera-space position, interpolated normal (not
// normalised), geometric normal, the key segment and time within it, and its ts_sample_density.
struct TexelAt {
    vec3 pos, n, geometric;
    uint seg;
    float s, density;
};

TexelAt texel_at(float t) {
    TexelAt x;
    x.seg = ts_locate(t, pc.segment_first, pc.segment_count, x.s);
    ObjectView ov = object_views[x.seg];
    mat3 n0 = mat3(ov.normal_matrix[0]), n1 = mat3(ov.normal_matrix[1]);
    vec3 tri[3];
    x.n = vec3(0.0);
    for (uint k = 0u; k < 3u; k++) {
        Vertex v = vertices[indices[3u * g_prim + k]];
        vec4 p = vec4(v.position[0], v.position[1], v.position[2], 1.0);
        vec3 a = (ov.model_view[0] * p).xyz, b = (ov.model_view[1] * p).xyz;
        tri[k] = a + (b - a) * x.s;
        vec3 nk = vec3(v.normal[0], v.normal[1], v.normal[2]);
        x.n += g_bary[k] * mix(n0 * nk, n1 * nk, x.s);
    }
    x.pos = g_bary.x * tri[0] + g_bary.y * tri[1] + g_bary.z * tri[2];
    x.geometric = cross(tri[1] - tri[0], tri[2] - tri[0]);
    x.density = ts_sample_density(tri, x.pos);
    return x;
}

bool in_front(TexelAt x) {
    return -x.pos.z >= view.lens.z && -x.pos.z <= view.lens.w;
}

// The texel's point x shaded at shutter time t (stochastic/shade.glsl's shade_at at the lens centre).
vec3 shade_texel(TexelAt x, float t, Material m, vec3 albedo) {
    vec3 to_eye = dot(x.pos, x.pos) > 0.0 ? normalize(-x.pos) : vec3(0.0, 0.0, 1.0);
    vec3 n;
    if (dot(x.n, x.n) > 0.0) n = normalize(x.n);
    else if (dot(x.geometric, x.geometric) > 0.0) n = normalize(x.geometric);
    else n = to_eye;
    // Two-sided: the side facing the lens centre at t.
    if (dot(n, to_eye) < 0.0) n = -n;
#ifdef SHADOWS
    shadow_receiver = ShadowReceiver(g_object_position, g_object_normal, ts_plane_normal, x.seg, x.s);
#endif
    return shade(x.pos, n, to_eye, albedo, m.albedo_specular.w, m.params.x, t);
}

void main() {
#ifdef SHADOWS
    // The receiver's plane in object space (it does not change with the shading time); derivatives
    // first, in uniform control flow.
    ts_plane_normal = shadow_plane_normal(g_object_position);
#endif
    Material m = materials[pc.object];
    vec3 albedo = m.albedo_specular.rgb;
    if (m.params.y > 0.5) albedo *= texture_prefiltered(g_uv, dFdx(g_uv), dFdy(g_uv), m.params.w > 0.5);
#ifdef CONSERVATIVE
    float marker = 0.5;
#else
    float marker = 1.0;
#endif
#ifdef INSTRUMENTED
#ifdef CONSERVATIVE
    atomicAdd(counters.gutter_texels, 1u);
#else
    atomicAdd(counters.shaded_texels, 1u);
#endif
#endif
    vec3 radiance;
    if (pc.shading_times <= 1u) {
        // Mid-shutter (the paper's time), from the geometry stage's varyings.
        vec3 n = dot(g_normal, g_normal) > 0.0 ? normalize(g_normal) : vec3(0.0, 0.0, 1.0);
        vec3 to_eye = normalize(-g_position);
        // Two-sided: the side facing the lens centre.
        if (dot(n, to_eye) < 0.0) n = -n;
#ifdef SHADOWS
        shadow_receiver = ShadowReceiver(g_object_position, g_object_normal, ts_plane_normal, pc.segment, pc.segment_time);
#endif
        radiance = shade(g_position, n, to_eye, albedo, m.albedo_specular.w, m.params.x, pc.time);
    } else {
        // Only the times at which samples see the point are shaded (the shading is the cost; behind
        // the camera or off the image it weighs nothing).
        vec3 seen = vec3(0.0);
        float seen_weight = 0.0;
        for (uint j = 0u; j < pc.shading_times; j++) {
            float t = ts_shading_time(j, pc.shading_times);
            TexelAt x = texel_at(t);
            if (x.density > 0.0) {
                seen += x.density * shade_texel(x, t, m, albedo);
                seen_weight += x.density;
            }
        }
        if (seen_weight > 0.0) {
            radiance = seen / seen_weight;
        } else {
            // Seen at none of them (a gutter texel past the image's edge, a point seen only between
            // them): the plain average over the times it is in front at, else over all.
            vec3 front = vec3(0.0), every = vec3(0.0);
            float front_count = 0.0;
            for (uint j = 0u; j < pc.shading_times; j++) {
                float t = ts_shading_time(j, pc.shading_times);
                TexelAt x = texel_at(t);
                vec3 c = shade_texel(x, t, m, albedo);
                bool f = in_front(x);
                front += f ? c : vec3(0.0);
                front_count += f ? 1.0 : 0.0;
                every += c;
            }
            radiance = front_count > 0.0 ? front / front_count : every / float(pc.shading_times);
        }
    }
    out_color = vec4(radiance, marker);
}
