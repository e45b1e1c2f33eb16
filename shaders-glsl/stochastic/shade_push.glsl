// The push constants every stochastic shading stage starts with: each stage file declares its own
// block, `ShadePush shade` first, then its own fields (shade_exact.comp, shade_texture_space.comp,
// shade_decoupled.comp). Mirrors `ShadePush` in engine/src/techniques/stochastic/shading/mod.rs; the
// coverage and tint draws push stochastic/visibility_push.glsl instead.
#ifndef SHUTTER_STOCHASTIC_SHADE_PUSH_GLSL
#define SHUTTER_STOCHASTIC_SHADE_PUSH_GLSL

struct ShadePush {
    uint object;      // index into `objects`, or SHADE_BACKGROUND (shade.glsl) for the empty samples
    uint pass_index;  // this pass holds samples [pass_index * per_pass, (pass_index + 1) * per_pass) of each pixel
    uint spp;         // S: samples per pixel over all passes (the sample tile's depth)
    uint per_pass;    // samples per pixel and pass (the visibility buffer's depth)
    // The dispatch covers the object's screen box from this pixel on.
    uint origin_x;
    uint origin_y;
    // The object's first triangle in the frame's numbering (visibility payloads) and its count.
    uint triangle_base;
    uint triangle_count;
    // The object's motion: its first key segment in object_views and its segment count.
    uint segment_first;
    uint segment_count;
};

#endif
