#version 460
// Stochastic rasterization, once per frame and object: every triangle in camera space at each motion
// key of its object (9 floats per key: vertices 0..2; stochastic/camera_triangles.glsl), so the
// fragment stage reads one record per fragment instead of fetching and transforming three vertices
// twice (thesis §9.6).
#include "common/frame.glsl"
#include "common/object.glsl"

layout(local_size_x = 64) in;

layout(set = 2, binding = 0, std430) writeonly buffer Triangles { float triangles[]; };

layout(push_constant) uniform Push {
    uint segment_first;  // the object's first key segment in object_views
    uint keys;           // its key count (segments + 1)
    uint triangle_count;
} pc;

void main() {
    uint t = gl_GlobalInvocationID.x;
    if (t >= pc.triangle_count) return;
    for (uint key = 0u; key < pc.keys; key++) {
        // Key j opens segment j; the last key closes the last segment.
        uint seg = min(key, pc.keys - 2u);
        mat4 mv = object_views[pc.segment_first + seg].model_view[key - seg];
        for (uint k = 0u; k < 3u; k++) {
            Vertex v = vertices[indices[3u * t + k]];
            vec3 p = transform_point_exact(mv, vec3(v.position[0], v.position[1], v.position[2]));
            for (uint c = 0u; c < 3u; c++) triangles[9u * (t * pc.keys + key) + 3u * k + c] = p[c];
        }
    }
}
