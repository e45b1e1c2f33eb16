#version 460
// Stochastic rasterization, once per frame and object: every triangle in camera space at shutter open
// and close (18 floats: open vertices 0..2, then close vertices 0..2), so the fragment stage reads one
// record per fragment instead of fetching and transforming three vertices twice (thesis §9.6).
#include "common/frame.glsl"
#include "common/object.glsl"

layout(local_size_x = 64) in;

layout(set = 2, binding = 0, std430) writeonly buffer Triangles { float triangles[]; };

layout(push_constant) uniform Push {
    uint object;
    uint triangle_count;
} pc;

void main() {
    uint t = gl_GlobalInvocationID.x;
    if (t >= pc.triangle_count) return;
    ObjectView o = object_views[pc.object];
    for (uint k = 0u; k < 3u; k++) {
        Vertex v = vertices[indices[3u * t + k]];
        vec4 p = vec4(v.position[0], v.position[1], v.position[2], 1.0);
        vec3 p0 = (o.model_view[0] * p).xyz;
        vec3 p1 = (o.model_view[1] * p).xyz;
        for (uint c = 0u; c < 3u; c++) {
            triangles[18u * t + 3u * k + c] = p0[c];
            triangles[18u * t + 9u + 3u * k + c] = p1[c];
        }
    }
}
