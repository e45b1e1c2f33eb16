// Reading the view's camera-space triangles (written by triangles.comp): per triangle, its three
// vertices (xyz each, 9 floats) at each of its object's K motion keys, key after key (K = 2, open and
// close, unless the object has more). TRIANGLE_KEY_BYTES in engine/src/techniques/stochastic.rs.
#ifndef SHUTTER_CAMERA_TRIANGLES_GLSL
#define SHUTTER_CAMERA_TRIANGLES_GLSL

layout(set = 2, binding = 0, std430) readonly buffer Triangles { float triangles[]; };

// Triangle `prim`'s vertices at the keys that bound segment `seg` of its object's `keys` keys.
void load_triangle(uint prim, uint seg, uint keys, out vec3 open[3], out vec3 close[3]) {
    for (uint k = 0u; k < 3u; k++) {
        uint at = 9u * (prim * keys + seg) + 3u * k;
        open[k] = vec3(triangles[at], triangles[at + 1u], triangles[at + 2u]);
        close[k] = vec3(triangles[at + 9u], triangles[at + 10u], triangles[at + 11u]);
    }
}

#endif
