// Reading the view's camera-space triangles (written by triangles.comp): 18 floats per triangle, its
// three vertices at shutter open (xyz each) then at close. TRIANGLE_RECORD_BYTES in
// engine/src/techniques/stochastic.rs.
#ifndef SHUTTER_CAMERA_TRIANGLES_GLSL
#define SHUTTER_CAMERA_TRIANGLES_GLSL

layout(set = 2, binding = 0, std430) readonly buffer Triangles { float triangles[]; };

// Triangle `prim`'s vertices at shutter open and close.
void load_triangle(uint prim, out vec3 open[3], out vec3 close[3]) {
    for (uint k = 0u; k < 3u; k++) {
        uint at = 18u * prim + 3u * k;
        open[k] = vec3(triangles[at], triangles[at + 1u], triangles[at + 2u]);
        close[k] = vec3(triangles[at + 9u], triangles[at + 10u], triangles[at + 11u]);
    }
}

#endif
