// Descriptor set 1, one object of the world: its albedo texture and its mesh, for stages that fetch
// vertices themselves. Mirrors engine/src/gpu/layout.rs (OBJECT_SET, Vertex).
#ifndef SHUTTER_OBJECT_GLSL
#define SHUTTER_OBJECT_GLSL

struct Vertex {
    float position[3];
    float normal[3];
    float uv[2];
};  // 32 bytes, as GpuWorld uploads them

layout(set = 1, binding = 0) uniform sampler2D albedo_texture;
layout(set = 1, binding = 1, std430) readonly buffer Vertices { Vertex vertices[]; };
layout(set = 1, binding = 2, std430) readonly buffer Indices { uint indices[]; };

#endif
