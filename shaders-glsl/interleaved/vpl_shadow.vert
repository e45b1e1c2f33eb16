#version 460
// Interleaved deferred shading's VPL shadow maps (the paper's SSM; engine/src/techniques/interleaved.rs):
// one cube face of one VPL per viewport of the atlas. The object's camera-space position at mid-shutter
// (as forward.vert, with no lens and no jitter) through the face's camera-space view-projection.
#include "common/frame.glsl"

layout(location = 0) in vec3 in_position;  // the world's vertex buffer, position only

layout(push_constant) uniform Push {
    mat4 face;     // camera space -> the face's clip space
    vec4 vpl;      // the VPL's position; w: the maps' far distance
    uint object;
    uint segment;  // the object's key segment holding mid-shutter
    float segment_time;
    uint pad;
} pc;

layout(location = 0) out vec3 v_position;

void main() {
    ObjectView o = object_views[pc.segment];
    vec3 p0 = (o.model_view[0] * vec4(in_position, 1.0)).xyz;
    vec3 p1 = (o.model_view[1] * vec4(in_position, 1.0)).xyz;
    vec3 p = p0 + (p1 - p0) * pc.segment_time;
    v_position = p;
    gl_Position = pc.face * vec4(p, 1.0);
}
