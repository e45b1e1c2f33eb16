#version 460
// Interleaved deferred shading's VPL shadow maps (the paper's SSM; engine/src/techniques/interleaved.rs):
// the cube faces of the pass' VPL set in one instanced draw per object, each instance one face the
// object can reach, drawn into the face's square of the atlas. One draw per face and object (thousands a pass) made llvmpipe's cost
// per draw the whole cost of a moving scene's maps; instancing removes it. The object's camera-space
// position at the pass' time (as forward.vert, with no lens and no jitter) through the face's
// camera-space view-projection; four clip distances cut the triangle to the face's frustum, as the
// face's own viewport would, and the face's clip space is then mapped onto its square of the atlas.
#include "common/frame.glsl"

layout(location = 0) in vec3 in_position;  // the world's vertex buffer, position only

struct Vpl {
    vec4 position;  // camera space; w unused
    vec4 normal;
    vec4 flux;
};
layout(set = 3, binding = 1, std430) readonly buffer Vpls { Vpl vpls[]; };
layout(set = 3, binding = 9, std430) readonly buffer VplFaces { mat4 vpl_faces[]; };
// Per object, the faces of the set its bounding sphere can reach (faces_meeting_sphere); the draw's
// instances index it.
layout(set = 3, binding = 13, std430) readonly buffer VplFaceLists { uint face_lists[]; };

layout(push_constant) uniform Push {
    uint object;
    uint segment;       // the object's key segment holding the pass' time
    float segment_time;
    uint first_face;    // the set's first face in vpl_faces: 6 × its first VPL
    uint atlas_cols;    // faces a row of the atlas
    uint face_size;     // texels a face's side
    float far;          // the maps' far distance
    uint pad;
    vec2 atlas_size;    // the atlas' texels
} pc;

layout(location = 0) out vec3 v_offset;  // from the VPL, interpolated linearly as the position is

out gl_PerVertex {
    vec4 gl_Position;
    float gl_ClipDistance[4];
};

void main() {
    ObjectView o = object_views[pc.segment];
    vec3 p0 = (o.model_view[0] * vec4(in_position, 1.0)).xyz;
    vec3 p1 = (o.model_view[1] * vec4(in_position, 1.0)).xyz;
    vec3 p = p0 + (p1 - p0) * pc.segment_time;
    uint face = face_lists[gl_InstanceIndex];
    v_offset = p - vpls[(pc.first_face + face) / 6u].position.xyz;
    vec4 clip = vpl_faces[pc.first_face + face] * vec4(p, 1.0);
    gl_ClipDistance[0] = clip.w + clip.x;
    gl_ClipDistance[1] = clip.w - clip.x;
    gl_ClipDistance[2] = clip.w + clip.y;
    gl_ClipDistance[3] = clip.w - clip.y;
    // The face's [-w, w] onto its square: framebuffer x = (x/w · ½ + ½ + col) · size, over the atlas.
    vec2 square = vec2(uvec2(face % pc.atlas_cols, face / pc.atlas_cols)) * float(pc.face_size);
    vec2 scale = float(pc.face_size) / pc.atlas_size;
    vec2 offset = (2.0 * square + float(pc.face_size)) / pc.atlas_size - 1.0;
    gl_Position = vec4(clip.xy * scale + clip.w * offset, clip.z, clip.w);
}
