// Conservative frustum culling of pass 1 over every lens point and shutter time. GLSL port of
// engine/src/mirror/texture_space/cull.rs (which derives the test): a triangle is culled when its vertices
// at every key of the object's motion lie outside one plane of the frustum widened by the lens —
// near, far, or an image edge pushed out by TS_CULL_MARGIN_PX, seen through any lens point; and, for
// one-sided materials, when every lens point at every time sees its back (ts_back_facing). Needs
// common/frame.glsl (viewport.xyz = width, height, pixel scale; lens = aperture radius, focus
// distance, near, far) and common/object.glsl (the object's mesh).
#ifndef SHUTTER_TEXTURE_SPACE_CULL_GLSL
#define SHUTTER_TEXTURE_SPACE_CULL_GLSL
#include "common/back_facing.glsl"

// texture_space::cull::CULL_MARGIN_PX.
const float TS_CULL_MARGIN_PX = 1.0;

// cull::outside_frustum over the object-space triangle `p` at both keys of the object's key segments
// first .. first + count (object_views).
bool ts_outside_frustum(vec3 p[3], uint first, uint count) {
    float s = view.viewport.z;
    float tx = (0.5 * view.viewport.x + TS_CULL_MARGIN_PX) / s;
    float ty = (0.5 * view.viewport.y + TS_CULL_MARGIN_PX) / s;
    float r = view.lens.x, f = view.lens.y;
    bool near_ = true, far_ = true, left = true, right = true, bottom = true, top = true;
    for (uint j = 0u; j < count; j++) {
        ObjectView ov = object_views[first + j];
        for (int e = 0; e < 2; e++) {
            for (int k = 0; k < 3; k++) {
                vec3 q = (ov.model_view[e] * vec4(p[k], 1.0)).xyz;
                float d = -q.z;
                float lens = r * abs(d / f - 1.0);
                near_ = near_ && d < view.lens.z;
                far_ = far_ && d > view.lens.w;
                left = left && q.x + tx * d + lens < 0.0;
                right = right && -q.x + tx * d + lens < 0.0;
                bottom = bottom && q.y + ty * d + lens < 0.0;
                top = top && -q.y + ty * d + lens < 0.0;
            }
        }
    }
    return near_ || far_ || left || right || bottom || top;
}

// cull::outside_frustum over the camera-space triangle `q` alone (one time: the rate's shading times,
// rate.glsl).
bool ts_outside_frustum_points(vec3 q[3]) {
    float s = view.viewport.z;
    float tx = (0.5 * view.viewport.x + TS_CULL_MARGIN_PX) / s;
    float ty = (0.5 * view.viewport.y + TS_CULL_MARGIN_PX) / s;
    float r = view.lens.x, f = view.lens.y;
    bool near_ = true, far_ = true, left = true, right = true, bottom = true, top = true;
    for (int k = 0; k < 3; k++) {
        float d = -q[k].z;
        float lens = r * abs(d / f - 1.0);
        near_ = near_ && d < view.lens.z;
        far_ = far_ && d > view.lens.w;
        left = left && q[k].x + tx * d + lens < 0.0;
        right = right && -q[k].x + tx * d + lens < 0.0;
        bottom = bottom && q[k].y + ty * d + lens < 0.0;
        top = top && -q[k].y + ty * d + lens < 0.0;
    }
    return near_ || far_ || left || right || bottom || top;
}

// cull::back_facing over the object-space triangle `p` moved by the object's key segments first ..
// first + count (object_views): its back faces every lens point (radius view.lens.x) at every time.
bool ts_back_facing(vec3 p[3], uint first, uint count) {
    bool back = true;
    for (uint j = 0u; j < count; j++) {
        ObjectView ov = object_views[first + j];
        vec3 a[3], b[3];
        for (int k = 0; k < 3; k++) {
            a[k] = (ov.model_view[0] * vec4(p[k], 1.0)).xyz;
            b[k] = (ov.model_view[1] * vec4(p[k], 1.0)).xyz;
        }
        back = back && back_facing_segment(view.lens.x, a, b);
    }
    return back;
}

#endif
