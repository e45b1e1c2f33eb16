#version 460
// Pass 1 of adaptive texture-space shading: no vertex input and nothing to do per vertex — the
// geometry stage fetches each triangle by gl_PrimitiveIDIn (engine/src/techniques/texture_space.rs).
void main() {
    gl_Position = vec4(0.0, 0.0, 0.0, 1.0);
}
