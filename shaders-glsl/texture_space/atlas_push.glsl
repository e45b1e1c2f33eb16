// Push constants of the shading-atlas passes (pass 1 of adaptive texture-space shading). Mirrors
// `AtlasPush` in engine/src/techniques/texture_space.rs.
#ifndef SHUTTER_TEXTURE_SPACE_ATLAS_PUSH_GLSL
#define SHUTTER_TEXTURE_SPACE_ATLAS_PUSH_GLSL

layout(push_constant) uniform Push {
    uint object;         // index into materials
    uint segment;        // the object's key segment holding mid-shutter (object_views index)
    float segment_time;  // mid-shutter's time within it
    uint finest;         // level 0's side, texels (texture_space::atlas::MipAtlas)
    uint gutter;         // texels between levels
    uint level_count;
    float hull_texels;   // half-size of the box the conservative sub-pass dilates by (0.5: one texel)
    float time;          // mid-shutter (the lights')
    uint atlas_width;    // the atlas image, texels
    uint atlas_height;
    uint segment_first;  // the object's key segments (object_views), for culling over the shutter
    uint segment_count;
    uint one_sided;      // 1: the material is one-sided, back faces are culled (texture_space/cull.glsl)
    uint shading_times;  // rate::shading_time_count: 1 shades at mid-shutter (segment, segment_time)
} pc;

// MipAtlas::level_rect's corner.
vec2 atlas_level_offset(uint level) {
    if (level == 0u) return vec2(0.0);
    uint y = 0u;
    for (uint k = 1u; k < level; k++) y += (pc.finest >> k) + pc.gutter;
    return vec2(float(pc.finest + pc.gutter), float(y));
}

#endif
