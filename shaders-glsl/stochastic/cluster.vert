#version 460
// Cluster bounds' vertex stage: six vertices per cluster (two triangles) covering its screen box from
// clusters.comp dilated by the pixel box (pc.dilate, as emit.glsl dilates every bound) and clamped to
// the viewport; an empty box collapses to a point. The fragment stage finds the cluster from
// gl_PrimitiveID (two triangles per cluster): the same for every fragment of a primitive, so the
// triangles it loads by it are loaded once for all the pixels llvmpipe shades together.
#include "common/frame.glsl"
#include "stochastic/visibility_push.glsl"

layout(set = 2, binding = 3, std430) readonly buffer Clusters { vec4 clusters[]; };

void main() {
    uint c = uint(gl_VertexIndex) / 6u;
    uint corner = uint(gl_VertexIndex) % 6u;
    uint clusters_n = (pc.triangle_count + pc.cluster_size - 1u) / pc.cluster_size;
    vec4 box = clusters[3u * (pc.segment * clusters_n + c)];
    vec2 size = view.viewport.xy;
    vec2 lo = clamp(box.xy - pc.dilate, vec2(0.0), size);
    vec2 hi = clamp(box.zw + pc.dilate, vec2(0.0), size);
    if (!(box.x <= box.z && box.y <= box.w)) hi = lo;  // empty (or NaN)
    // Corners of the two triangles (0, 1, 2), (2, 1, 3) of the box.
    const uvec2 CORNERS[6] = uvec2[6](uvec2(0u, 0u), uvec2(1u, 0u), uvec2(0u, 1u), uvec2(0u, 1u), uvec2(1u, 0u), uvec2(1u, 1u));
    uvec2 k = CORNERS[corner];
    vec2 p = vec2(k.x == 0u ? lo.x : hi.x, k.y == 0u ? lo.y : hi.y);
    gl_Position = vec4(2.0 * p / size - 1.0, 0.5, 1.0);
}
