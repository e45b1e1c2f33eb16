#version 460
// Stochastic rasterization, vertex stage: the vertex in camera space at the two keys of the draw's
// motion segment. The geometry stage bounds the triangle over the draw's time and the lens; nothing is
// projected here.
#include "common/frame.glsl"
#include "stochastic/visibility_push.glsl"

layout(location = 0) in vec3 in_position;

layout(location = 0) out vec3 v_open;
layout(location = 1) out vec3 v_close;

void main() {
    ObjectView o = object_views[pc.segment_first + pc.segment];
    v_open = transform_point_exact(o.model_view[0], in_position);  // as triangles.comp
    v_close = transform_point_exact(o.model_view[1], in_position);
    gl_Position = vec4(v_open, 1.0);  // unused: the geometry stage writes the hull's positions
}
