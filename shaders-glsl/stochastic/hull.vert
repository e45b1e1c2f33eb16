#version 460
// The compute-expanded hull's vertex stage: one vertex of expand.comp's triangle list, by index (no
// vertex input); the triangle's index goes to the fragment stage flat (it reads the triangle by it,
// as it reads gl_PrimitiveID behind the geometry shader).
layout(set = 2, binding = 3, std430) readonly buffer Hull { float hull[]; };

layout(location = 0) flat out uint v_triangle;

void main() {
    uint at = 3u * uint(gl_VertexIndex);
    gl_Position = vec4(hull[at], hull[at + 1u], 0.5, 1.0);
    v_triangle = floatBitsToUint(hull[at + 2u]);
}
