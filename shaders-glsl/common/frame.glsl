// Per-frame data shared by every technique: camera intrinsics, lens, lights at shutter open and close.
// Mirrors engine/src/techniques/gpu_scene.rs (FrameUniforms, ObjectData). Camera space throughout:
// +Y up, looking down -Z, view depth z = -p.z (DESIGN.md).
#ifndef SHUTTER_FRAME_GLSL
#define SHUTTER_FRAME_GLSL

#define MAX_LIGHTS 16
#define LIGHT_DIRECTIONAL 0.0
#define LIGHT_POINT 1.0

struct Light {
    vec4 at_open;   // xyz: direction to light (directional) or position (point); w: type
    vec4 at_close;  // the same at shutter close
    vec4 color;     // rgb
};

layout(set = 0, binding = 0, std140) uniform FrameUniforms {
    vec4 viewport;    // width, height, pixel_scale s, light_count
    vec4 lens;        // aperture_radius A, focus_distance F, near, far
    vec4 ambient;     // rgb
    vec4 background;  // rgb
    Light lights[MAX_LIGHTS];
} frame;

struct ObjectData {
    mat4 model_view[2];     // object -> camera space at shutter open, close
    mat4 normal_matrix[2];  // inverse transpose of the upper 3x3 (in a mat4 for std430 alignment)
    vec4 albedo_specular;   // rgb albedo, specular weight
    vec4 material;          // roughness, has_texture, alpha, unused
};

layout(set = 0, binding = 1, std430) readonly buffer Objects { ObjectData objects[]; };

#endif
