#version 460
// Pass 1 of adaptive texture-space shading (Andersson et al. 2014, §3.1.3), geometry stage: triangle
// gl_PrimitiveIDIn of the object at mid-shutter gets its level (texture_space/rate.glsl) and is
// placed in the shading atlas at that level — T / 2^level + the level's corner, T its shading
// coordinate in texels of level 0 — with its camera-space position, normal and uv as varyings.
//   default ("shade" sub-pass): the triangle itself at depth 0.25; it records its level for pass 2.
//   CONSERVATIVE ("conservative" sub-pass): the triangle's outer hull at that level — its Minkowski
//     sum with a box of half-size hull_texels, so every texel whose square it touches gets a fragment
//     (Hasselgren, Akenine-Möller & Ohlsson 2005) — varyings extrapolated affinely from the triangle,
//     at depth 0.75 behind the shade sub-pass' 0.25 with the depth test LESS: texels the shade
//     sub-pass wrote keep their values and only the gutters around edges, which a bilinear lookup
//     near an edge reads, are added.
//   SHADOW_RECEIVER: also the object-space position and normal, for the shadow-map lookups of
//     atlas.frag (SHADOWS).
// With several shading times (pc.shading_times > 1: the object turns in camera space within the
// shutter) the level is the finest over them (ts_triangle_level_over_shutter), and the fragment stage
// shades at each from the triangle's barycentrics (g_bary, g_prim) rather than the mid-shutter
// varyings. A triangle without a footprint (behind the camera or edge-on at every vertex — at every
// shading time) emits nothing; nor
// does one no sample can hit, at any lens point or time (texture_space/cull.glsl: outside the frustum,
// or a one-sided material's back face): its level record says so (w = 2).
#include "common/frame.glsl"
#include "common/object.glsl"
#include "texture_space/rate.glsl"
#include "texture_space/cull.glsl"
#include "texture_space/atlas_push.glsl"

layout(triangles) in;
layout(triangle_strip, max_vertices = 16) out;

layout(set = 3, binding = 0, std430) readonly buffer ShadingCoords { vec2 shading_coords[]; };
// Per triangle: minor radius, grid spacing, level, then 1 with a footprint, 2 with one but culled, 0
// without (levels.comp's layout, but for the culled; pass 2 reads the level).
layout(set = 3, binding = 1, std430) buffer Levels { vec4 levels[]; };

layout(location = 0) out vec3 g_position;  // camera space, mid-shutter
layout(location = 1) out vec3 g_normal;
layout(location = 2) out vec2 g_uv;
#ifdef SHADOW_RECEIVER
// Object space, for the shadow-map lookups in the lights' own spaces (common/shadow.glsl).
layout(location = 3) out vec3 g_object_position;
layout(location = 4) out vec3 g_object_normal;
#endif
// The barycentrics of triangle g_prim (affinely extended past its edges, as every varying), for the
// shading at several times (atlas.frag).
layout(location = 5) out vec3 g_bary;
layout(location = 6) flat out uint g_prim;

#ifdef CONSERVATIVE
const float DEPTH = 0.75;
#else
const float DEPTH = 0.25;
#endif

vec3 tri_p[3];
vec3 tri_n[3];
vec3 tri_object_p[3];
vec3 tri_object_n[3];
vec2 tri_uv[3];
vec2 atlas_p[3];

// One strip vertex at atlas point a (texels), its varyings the triangle's affine extension.
void emit_at(vec2 a) {
    vec2 e1 = atlas_p[1] - atlas_p[0], e2 = atlas_p[2] - atlas_p[0], d = a - atlas_p[0];
    float det = e1.x * e2.y - e1.y * e2.x;
    float b1 = (d.x * e2.y - d.y * e2.x) / det, b2 = (e1.x * d.y - e1.y * d.x) / det;
    vec3 w = vec3(1.0 - b1 - b2, b1, b2);
    g_position = w.x * tri_p[0] + w.y * tri_p[1] + w.z * tri_p[2];
    g_normal = w.x * tri_n[0] + w.y * tri_n[1] + w.z * tri_n[2];
    g_uv = w.x * tri_uv[0] + w.y * tri_uv[1] + w.z * tri_uv[2];
    g_bary = w;
    g_prim = uint(gl_PrimitiveIDIn);
#ifdef SHADOW_RECEIVER
    g_object_position = w.x * tri_object_p[0] + w.y * tri_object_p[1] + w.z * tri_object_p[2];
    g_object_normal = w.x * tri_object_n[0] + w.y * tri_object_n[1] + w.z * tri_object_n[2];
#endif
    vec2 size = vec2(float(pc.atlas_width), float(pc.atlas_height));
    gl_Position = vec4(2.0 * a / size - 1.0, DEPTH, 1.0);
    EmitVertex();
}

// Quadrant of a direction, counter-clockwise from +x: box corner (sign x, sign y) supports it
// (stochastic/emit.glsl's rule).
int quadrant(vec2 n) {
    if (n.x > 0.0 && n.y >= 0.0) return 0;
    if (n.x <= 0.0 && n.y > 0.0) return 1;
    if (n.x < 0.0 && n.y <= 0.0) return 2;
    return 3;
}

vec2 box_corner(int q) {
    const vec2 c[4] = vec2[4](vec2(1.0, 1.0), vec2(-1.0, 1.0), vec2(-1.0, -1.0), vec2(1.0, -1.0));
    return c[q] * pc.hull_texels;
}

void main() {
    uint prim = uint(gl_PrimitiveIDIn);
    ObjectView ov = object_views[pc.segment];
    vec2 tex[3];
    vec3 object_p[3];
    for (uint k = 0u; k < 3u; k++) {
        Vertex v = vertices[indices[3u * prim + k]];
        vec4 p = vec4(v.position[0], v.position[1], v.position[2], 1.0);
        object_p[k] = p.xyz;
        vec3 a = (ov.model_view[0] * p).xyz, b = (ov.model_view[1] * p).xyz;
        tri_p[k] = a + (b - a) * pc.segment_time;
        vec3 n = vec3(v.normal[0], v.normal[1], v.normal[2]);
        tri_object_p[k] = p.xyz;
        tri_object_n[k] = n;
        tri_n[k] = mix(mat3(ov.normal_matrix[0]) * n, mat3(ov.normal_matrix[1]) * n, pc.segment_time);
        tri_uv[k] = vec2(v.uv[0], v.uv[1]);
        tex[k] = shading_coords[3u * prim + k];
    }
    if (dot(tri_object_n[0], tri_object_n[0]) == 0.0) {
        // No vertex normals (common/shadow.glsl offsets the receiver along its normal): the face's.
        vec3 f = cross(object_p[1] - object_p[0], object_p[2] - object_p[0]);
        for (int k = 0; k < 3; k++) tri_object_n[k] = f;
    }
#ifndef CONSERVATIVE
    float radius, spacing;
    uint level;
    bool ok = ts_triangle_level_over_shutter(tri_p, object_p, tex, pc.level_count, pc.segment_first,
                                             pc.segment_count, pc.shading_times, radius, spacing, level);
    bool culled = ts_outside_frustum(object_p, pc.segment_first, pc.segment_count)
               || (pc.one_sided != 0u && ts_back_facing(object_p, pc.segment_first, pc.segment_count));
    levels[prim] = vec4(radius, spacing, float(level), ok ? (culled ? 2.0 : 1.0) : 0.0);
    if (!ok || culled) return;
#else
    // The shade sub-pass' record (its pass ran before this one): the same level and verdict, not
    // computed twice.
    vec4 record = levels[prim];
    if (record.w != 1.0) return;
    uint level = uint(record.z);
#endif
    float scale = 1.0 / float(1u << level);
    vec2 corner = atlas_level_offset(level);
    for (int k = 0; k < 3; k++) atlas_p[k] = tex[k] * scale + corner;
    vec2 e1 = atlas_p[1] - atlas_p[0], e2 = atlas_p[2] - atlas_p[0];
    float area = e1.x * e2.y - e1.y * e2.x;
    if (area == 0.0 || isnan(area)) return;
#ifndef CONSERVATIVE
    for (int k = 0; k < 3; k++) emit_at(atlas_p[k]);
    EndPrimitive();
#else
    // The hull's vertices in counter-clockwise order: each corner followed by the box corners its
    // normal cone sweeps (at most 3 + 4 in all beyond the corners: 7 + 3 = 10 points).
    vec2 ccw[3] = area > 0.0 ? vec2[3](atlas_p[0], atlas_p[1], atlas_p[2])
                             : vec2[3](atlas_p[0], atlas_p[2], atlas_p[1]);
    vec2 q[12];
    int m = 0;
    for (int i = 0; i < 3; i++) {
        vec2 prev = ccw[(i + 2) % 3], cur = ccw[i], next = ccw[(i + 1) % 3];
        vec2 ea = cur - prev, eb = next - cur;
        int qa = quadrant(vec2(ea.y, -ea.x));
        int qb = quadrant(vec2(eb.y, -eb.x));
        q[m++] = cur + box_corner(qa);
        for (int k = 0; k < 4 && qa != qb; k++) {
            qa = (qa + 1) & 3;
            q[m++] = cur + box_corner(qa);
        }
    }
    for (int k = 0; k < m; k++) {
        int idx = (k & 1) == 1 ? (k + 1) / 2 : (m - k / 2) % m;
        emit_at(q[idx]);
    }
    EndPrimitive();
#endif
}
