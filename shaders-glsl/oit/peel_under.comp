#version 460
// Depth peeling (engine/src/techniques/oit.rs): after layer `layer` is peeled, composite it under the
// layers before it, per sample, front to back (Porter-Duff under with a per-channel transmittance):
//   colour += transmittance * (alpha * C)_layer;   transmittance *= ((1 - alpha) * tint)_layer
// A sample the layer did not reach holds (0, 1), which changes nothing. After the last layer, each
// sample's opaque colour is added behind what remains of the transmittance, the samples are averaged
// (the box filter of the resolve) and the pixel is added with `weight` (1 / passes) into the
// accumulation image, as accumulation/accumulate.comp does for the other forward passes.
layout(local_size_x = 8, local_size_y = 8) in;

#ifdef MULTISAMPLED
layout(set = 3, binding = 0) uniform sampler2DMS layer_color;
layout(set = 3, binding = 1) uniform sampler2DMS layer_transmittance;
layout(set = 3, binding = 2) uniform sampler2DMS opaque_color;
#define FETCH(map, p, s) texelFetch(map, p, int(s))
#else
layout(set = 3, binding = 0) uniform sampler2D layer_color;
layout(set = 3, binding = 1) uniform sampler2D layer_transmittance;
layout(set = 3, binding = 2) uniform sampler2D opaque_color;
#define FETCH(map, p, s) texelFetch(map, p, 0)
#endif
// Per sample: [2i] the colour composited so far, [2i + 1] the transmittance left (rgb).
layout(set = 3, binding = 3, std430) buffer PeelAccumulators { vec4 peel_accumulators[]; };
layout(set = 3, binding = 4, rgba32f) uniform image2D accum;

layout(push_constant) uniform Push {
    float weight;  // 1 / passes
    uint msaa;
    uint layer;    // 0: the nearest (the accumulators start from it)
    uint last;     // 1: the last layer (composite over the opaque colour, accumulate)
} pc;

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(accum);
    if (any(greaterThanEqual(p, size))) return;
    vec3 pixel = vec3(0.0);
    for (uint s = 0u; s < pc.msaa; ++s) {
        uint i = 2u * ((uint(p.y) * uint(size.x) + uint(p.x)) * pc.msaa + s);
        vec3 c = FETCH(layer_color, p, s).rgb;
        vec3 t = FETCH(layer_transmittance, p, s).rgb;
        if (pc.layer > 0u) {
            vec3 t_front = peel_accumulators[i + 1u].rgb;
            c = peel_accumulators[i].rgb + t_front * c;
            t = t_front * t;
        }
        if (pc.last != 0u) {
            pixel += c + t * FETCH(opaque_color, p, s).rgb;
        } else {
            peel_accumulators[i] = vec4(c, 0.0);
            peel_accumulators[i + 1u] = vec4(t, 0.0);
        }
    }
    if (pc.last != 0u) imageStore(accum, p, imageLoad(accum, p) + pc.weight * vec4(pixel / float(pc.msaa), 1.0));
}
