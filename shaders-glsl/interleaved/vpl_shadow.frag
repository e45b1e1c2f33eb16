#version 460
// The VPL shadow maps' depth: the distance from the VPL over the far distance (the lookup in shade.comp
// compares distances, independent of the face's projection).
layout(push_constant) uniform Push {
    mat4 face;
    vec4 vpl;
    uint object;
    uint segment;
    float segment_time;
    uint pad;
} pc;

layout(location = 0) in vec3 v_position;

void main() {
    gl_FragDepth = length(v_position - pc.vpl.xyz) / pc.vpl.w;
}
