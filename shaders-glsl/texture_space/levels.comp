#version 460
// Adaptive texture-space shading: the shading rate of every triangle of one object at mid-shutter, or
// over its shading times where it turns in camera space (texture_space/rate.glsl,
// ts_triangle_level_over_shutter), written per triangle — what pass 1's geometry shader will compute, run
// here on its own so that tests compare it with the CPU mirror (engine/src/mirror/texture_space/rate.rs).
#include "common/frame.glsl"
#include "common/object.glsl"
#include "texture_space/rate.glsl"

layout(local_size_x = 64) in;

// Per corner (3 per triangle, index order): the shading coordinate in texels of level 0.
layout(set = 3, binding = 0, std430) readonly buffer ShadingCoords { vec2 shading_coords[]; };
// Per triangle: minor radius (texels), grid spacing (px), level, 1 if it has a footprint.
layout(set = 3, binding = 1, std430) writeonly buffer Levels { vec4 levels[]; };

layout(push_constant) uniform Push {
    uint triangle_count;
    uint segment;        // the object's key segment holding mid-shutter (object_views index)
    float segment_time;  // mid-shutter's time within it
    uint level_count;    // levels of the object's atlas
    uint segment_first;  // the object's key segments (object_views)
    uint segment_count;
    uint shading_times;  // rate::shading_time_count
} pc;

void main() {
    uint t = gl_GlobalInvocationID.x;
    if (t >= pc.triangle_count) return;
    ObjectView ov = object_views[pc.segment];
    vec3 tri[3], object_p[3];
    vec2 tex[3];
    for (uint k = 0u; k < 3u; k++) {
        Vertex v = vertices[indices[3u * t + k]];
        vec4 p = vec4(v.position[0], v.position[1], v.position[2], 1.0);
        object_p[k] = p.xyz;
        vec3 a = (ov.model_view[0] * p).xyz, b = (ov.model_view[1] * p).xyz;
        tri[k] = a + (b - a) * pc.segment_time;
        tex[k] = shading_coords[3u * t + k];
    }
    float radius, spacing;
    uint level;
    bool ok = ts_triangle_level_over_shutter(tri, object_p, tex, pc.level_count, pc.segment_first,
                                             pc.segment_count, pc.shading_times, radius, spacing, level);
    levels[t] = vec4(radius, spacing, float(level), ok ? 1.0 : 0.0);
}
