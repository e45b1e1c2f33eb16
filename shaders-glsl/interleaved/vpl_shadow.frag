#version 460
// The VPL shadow maps' depth: the distance from the VPL over the far distance (the lookup in shade.comp
// compares distances, independent of the face's projection).
layout(push_constant) uniform Push {
    uint object;
    uint segment;
    float segment_time;
    uint first_face;
    uint atlas_cols;
    uint face_size;
    float far;
    uint pad;
    vec2 atlas_size;
} pc;

layout(location = 0) in vec3 v_offset;

void main() {
    gl_FragDepth = length(v_offset) / pc.far;
}
