#version 460
// Accumulation buffer (Haeberli & Akeley 1990): accum += weight * resolved pass image.
layout(local_size_x = 8, local_size_y = 8) in;
// Set 3 (technique; engine/src/techniques/multipass.rs ACCUMULATE_SET).
layout(set = 3, binding = 0, rgba32f) uniform readonly image2D resolved_pass;
layout(set = 3, binding = 1, rgba32f) uniform image2D accum;
layout(push_constant) uniform Push { float weight; } pc;
void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(p, imageSize(accum)))) return;
    imageStore(accum, p, imageLoad(accum, p) + pc.weight * imageLoad(resolved_pass, p));
}
