// The per-triangle shading rate of adaptive texture-space shading (Andersson et al. 2014, §3.1.1 and
// Appendix A). GLSL port of engine/src/mirror/texture_space/rate.rs, which documents the steps; the view's
// intrinsics come from common/frame.glsl (viewport.xyz = width, height, pixel scale; lens.xy =
// aperture radius, focus distance). Camera space, lens centre. Needs common/frame.glsl (object_views).
#ifndef SHUTTER_TEXTURE_SPACE_RATE_GLSL
#define SHUTTER_TEXTURE_SPACE_RATE_GLSL
#include "texture_space/cull.glsl"

// rate::min_coc_px: the smallest |phi(z)| over the vertices' depths, 0 across the focus plane.
float ts_min_coc_px(vec3 depths) {
    float f = view.lens.y;
    bool nearer = any(lessThanEqual(depths, vec3(f)));
    bool farther = any(greaterThanEqual(depths, vec3(f)));
    if (nearer && farther) return 0.0;
    vec3 coc = abs(view.lens.x * view.viewport.z * (1.0 / f - 1.0 / depths));
    return min(coc.x, min(coc.y, coc.z));
}

// rate::grid_spacing_px (a circular lens).
float ts_grid_spacing_px(float min_coc) {
    return max(0.5 * min_coc, 1.0);
}

// Intrinsics::project at the lens centre.
vec2 ts_project(vec3 p) {
    float z = -p.z;
    vec2 q = p.xy / z;
    return vec2(0.5 * view.viewport.x + view.viewport.z * q.x, 0.5 * view.viewport.y - view.viewport.z * q.y);
}

// rate::screen_derivatives: dT/dx and dT/dy at `pixel` along the lens-centre ray; false where the ray
// meets the triangle's plane behind the camera or edge-on, or the triangle is degenerate.
bool ts_screen_derivatives(vec3 tri[3], vec2 tex[3], vec2 pixel, out vec2 dx, out vec2 dy) {
    dx = vec2(0.0);
    dy = vec2(0.0);
    vec3 e1 = tri[1] - tri[0], e2 = tri[2] - tri[0];
    vec3 n = cross(e1, e2);
    float nn = dot(n, n);
    if (nn == 0.0 || isinf(nn) || isnan(nn)) return false;
    float s = view.viewport.z;
    vec2 tan_xy = vec2((pixel.x - 0.5 * view.viewport.x) / s, -(pixel.y - 0.5 * view.viewport.y) / s);
    vec3 dir = vec3(tan_xy, -1.0);
    vec3 ddir_dx = vec3(1.0 / s, 0.0, 0.0), ddir_dy = vec3(0.0, -1.0 / s, 0.0);
    float nv = dot(n, tri[0]), nd = dot(n, dir);
    if (nd == 0.0) return false;
    float lambda = nv / nd;
    if (!(lambda > 0.0) || isinf(lambda)) return false;
    vec3 g1 = cross(e2, n) / nn, g2 = cross(n, e1) / nn;
    vec2 t1 = tex[1] - tex[0], t2 = tex[2] - tex[0];
    vec3 dpx = lambda * ddir_dx - (nv * dot(n, ddir_dx) / (nd * nd)) * dir;
    vec3 dpy = lambda * ddir_dy - (nv * dot(n, ddir_dy) / (nd * nd)) * dir;
    dx = t1 * dot(g1, dpx) + t2 * dot(g2, dpx);
    dy = t1 * dot(g1, dpy) + t2 * dot(g2, dpy);
    return !(any(isnan(dx)) || any(isinf(dx)) || any(isnan(dy)) || any(isinf(dy)));
}

// rate::Ellipse::minor_radius of the footprint of (dx, dy) (Heckbert's coefficients).
float ts_minor_radius(vec2 dx, vec2 dy) {
    float a = dx.y * dx.y + dy.y * dy.y;
    float b = -2.0 * (dx.x * dx.y + dy.x * dy.y);
    float c = dx.x * dx.x + dy.x * dy.x;
    float det = dx.x * dy.y - dy.x * dx.y;
    float f = det * det;
    float r = sqrt((a - c) * (a - c) + b * b);
    float denominator = a + c + r;
    return denominator > 0.0 ? sqrt(2.0 * f / denominator) : 0.0;
}

// rate::level_of: floor(log2 r) clamped to [0, levels).
uint ts_level_of(float radius, uint levels) {
    if (!(radius >= 2.0)) return 0u;
    return min(uint(floor(log2(radius))), levels - 1u);
}

// rate::triangle_level: the smallest footprint minor radius over the vertices (texels of level 0),
// the grid spacing and the level; false when no vertex has a footprint.
bool ts_triangle_level(vec3 tri[3], vec2 tex[3], uint levels, out float radius, out float spacing,
                       out uint level) {
    spacing = ts_grid_spacing_px(ts_min_coc_px(vec3(-tri[0].z, -tri[1].z, -tri[2].z)));
    radius = uintBitsToFloat(0x7f800000u);
    bool any_vertex = false;
    for (int k = 0; k < 3; k++) {
        vec2 dx, dy;
        if (ts_screen_derivatives(tri, tex, ts_project(tri[k]), dx, dy)) {
            radius = min(radius, ts_minor_radius(spacing * dx, spacing * dy));
            any_vertex = true;
        }
    }
    level = ts_level_of(radius, levels);
    return any_vertex;
}

// rate::shading_time: time j of `count` shading times (the midpoints of count equal parts of the
// shutter; mid-shutter for one).
float ts_shading_time(uint j, uint count) {
    return (float(j) + 0.5) / float(count);
}

// The object's key segment (object_views index, of first .. first + count) holding shutter time t and
// the time within it (KeyTimes::locate). Needs common/frame.glsl's object_views.
uint ts_locate(float t, uint first, uint count, out float s) {
    uint seg = 0u;
    for (uint j = 1u; j < count; j++) {
        if (object_views[first + j].time.x <= t) seg = j;
    }
    s = segment_time(object_views[first + seg], t);
    return first + seg;
}

// rate::triangle_level_over_shutter: with one shading time, ts_triangle_level on `mid` (the caller's
// mid-shutter triangle); with more (an object that turns in camera space), the finest over the
// shading times at which the triangle has a footprint and is not outside the frustum (widened by the
// lens: cull.glsl), else — seen only between them — the finest over those with a footprint;
// object-space `object_p` moved by the object's key segments first .. first + count.
bool ts_triangle_level_over_shutter(vec3 mid[3], vec3 object_p[3], vec2 tex[3], uint levels, uint first,
                                    uint count, uint times, out float radius, out float spacing,
                                    out uint level) {
    if (times <= 1u) return ts_triangle_level(mid, tex, levels, radius, spacing, level);
    // Index 0: the times it may be seen at; 1: every time with a footprint.
    bool any_time[2] = bool[2](false, false);
    float radii[2] = float[2](0.0, 0.0), spacings[2] = float[2](1.0, 1.0);
    uint levels_at[2] = uint[2](0u, 0u);
    for (uint j = 0u; j < times; j++) {
        float s;
        ObjectView ov = object_views[ts_locate(ts_shading_time(j, times), first, count, s)];
        vec3 tri[3];
        for (int k = 0; k < 3; k++) {
            vec4 p = vec4(object_p[k], 1.0);
            vec3 a = (ov.model_view[0] * p).xyz, b = (ov.model_view[1] * p).xyz;
            tri[k] = a + (b - a) * s;
        }
        float r, d;
        uint l;
        if (!ts_triangle_level(tri, tex, levels, r, d, l)) continue;
        bool seen = !ts_outside_frustum_points(tri);
        for (int i = 0; i < 2; i++) {
            if ((i == 1 || seen) && (!any_time[i] || r < radii[i])) {
                radii[i] = r;
                spacings[i] = d;
                levels_at[i] = l;
                any_time[i] = true;
            }
        }
    }
    int i = any_time[0] ? 0 : 1;
    radius = radii[i];
    spacing = spacings[i];
    level = levels_at[i];
    return any_time[i];
}

#endif
