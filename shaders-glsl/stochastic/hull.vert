#version 460
// The compute-expanded hull's vertex stage: one vertex of expand.comp's triangle list, by index (no
// vertex input); the source triangle's index goes to the fragment stage flat (it reads the triangle by
// it, as it reads gl_PrimitiveID behind the geometry shader).
layout(set = 2, binding = 1, std430) readonly buffer Hull { vec2 hull[]; };
layout(set = 2, binding = 2, std430) readonly buffer HullTriangles { uint hull_triangle[]; };

layout(location = 0) flat out uint v_triangle;

void main() {
    gl_Position = vec4(hull[gl_VertexIndex], 0.5, 1.0);
    v_triangle = hull_triangle[uint(gl_VertexIndex) / 3u];
}
