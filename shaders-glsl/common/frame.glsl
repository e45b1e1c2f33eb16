// Descriptor set 0, the frame: the world (uploaded once per scene) and one view (the camera, or a
// light's shadow-map view). Mirrors engine/src/gpu/layout.rs (FRAME_SET, WorldUniforms, GpuMaterial,
// ViewUniforms, GpuObjectView); a SPIR-V reflection test checks bindings, sizes and offsets.
// View space throughout: +Y up, looking down -Z, view depth z = -p.z (docs/MODEL.md).
#ifndef SHUTTER_FRAME_GLSL
#define SHUTTER_FRAME_GLSL

#define MAX_LIGHTS 256
#define LIGHT_DIRECTIONAL 0.0
#define LIGHT_POINT 1.0
#define LIGHT_SPOT 2.0
#define PROJECTION_THIN_LENS 0.0
#define PROJECTION_ORTHOGRAPHIC 1.0
#define PROJECTION_PERSPECTIVE 2.0

struct Light {
    vec4 at_open;     // xyz: direction to light (directional) or position (point, spot), in view space; w: type
    vec4 at_close;    // the same at shutter close
    vec4 color;       // rgb
    vec4 spot_open;   // spot: xyz unit axis (into the scene) at shutter open, w cos(inner half-angle)
    vec4 spot_close;  // spot: xyz axis at shutter close, w cos(outer half-angle)
};

struct Material {
    vec4 albedo_specular;  // rgb albedo, specular weight
    vec4 params;           // roughness, has_texture, alpha, alpha_from_texture
};

// One key segment of an object's motion (an object's segments are consecutive).
struct ObjectView {
    mat4 model_view[2];     // object -> view space at the segment's first and last key
    mat4 normal_matrix[2];  // inverse transpose of the upper 3x3 (in a mat4 for std430 alignment)
    vec4 time;              // the keys' shutter times t0, t1, then 1 / (t1 - t0), unused
};

// The time within segment `s` of shutter time `t` (geometry::KeyTimes::local_time).
float segment_time(ObjectView s, float t) {
    return min((t - s.time.x) * s.time.z, 1.0);
}

layout(set = 0, binding = 0, std140) uniform WorldUniforms {
    vec4 ambient;     // rgb
    vec4 background;  // rgb
} world;

layout(set = 0, binding = 1, std430) readonly buffer Materials { Material materials[]; };

layout(set = 0, binding = 2, std140) uniform ViewUniforms {
    vec4 viewport;    // width, height, pixel_scale s (thin lens, perspective), light_count
    vec4 lens;        // aperture_radius A, focus_distance F, near, far
    vec4 projection;  // kind (PROJECTION_*), orthographic half extents x, y, unused
    Light lights[MAX_LIGHTS];
} view;

layout(set = 0, binding = 3, std430) readonly buffer ObjectViews { ObjectView object_views[]; };

// Object-space point p through m: glam's Mat4::transform_point3 (ObjectMotion::positions, the
// reference's vertices), operation for operation and without fused multiply-adds (precise), so that
// the stochastic rasterizer's camera-space vertices are the reference's bit for bit. `m * vec4(p, 1)`
// rounds differently, and far from the camera one ulp of a vertex is a sizeable part of a pixel
// (20 km away through a 0.001 degree lens, a fifth of one).
vec3 transform_point_exact(mat4 m, vec3 p) {
    precise vec3 r = m[0].xyz * p.x;
    r = m[1].xyz * p.y + r;
    r = m[2].xyz * p.z + r;
    r = m[3].xyz + r;
    return r;
}

#endif
