#version 460
// Depth-based stochastic transparency, pass 3 (engine/src/techniques/oit.rs). After each frame pass,
// per pixel, the means over its M samples of
//   C_opaque * T   (T the exact total transmittance, per channel)   -> accum
//   sum            (the layer sum: vis * alpha * C)                 -> sum_total
//   weight         (vis * effective coverage; its exact value is 1 - T) -> weight_total
//   1 - T                                                           -> absorbed_total
// are added with `weight` (1 / passes). Once after the last pass (`finish`), the layer sum is added
// to the accumulation image, with the alpha correction (Enderton et al. 2011) rescaled so that its
// weights sum to what they must:
//   L = sum_total * absorbed_total / weight_total          (per channel)
// The ratio is formed from the frame's sums over all S = M x passes samples, not per pass: at one
// sample per pass (accumulation) a per-pass ratio would be a ratio of one-sample estimates, whose
// bias does not average away over the passes.
// Alpha-corrected stochastic transparency (alpha_correction == 2) uses the same sums: the layer sum
// holds the colour of the samples whose nearest covered surface is transparent (alpha = 1 on each of
// them), so its weight is that count, and what it must sum to is the exact total alpha 1 - prod(1 - a),
// 1 minus the transmittance's alpha, in every channel.
layout(local_size_x = 8, local_size_y = 8) in;

#ifdef MULTISAMPLED
layout(set = 3, binding = 0) uniform sampler2DMS opaque_color;
layout(set = 3, binding = 1) uniform sampler2DMS layer_sum;
layout(set = 3, binding = 2) uniform sampler2DMS layer_weight;
layout(set = 3, binding = 3) uniform sampler2DMS total_transmittance;
#define FETCH(map, p, s) texelFetch(map, p, int(s))
#else
layout(set = 3, binding = 0) uniform sampler2D opaque_color;
layout(set = 3, binding = 1) uniform sampler2D layer_sum;
layout(set = 3, binding = 2) uniform sampler2D layer_weight;
layout(set = 3, binding = 3) uniform sampler2D total_transmittance;
#define FETCH(map, p, s) texelFetch(map, p, 0)
#endif
layout(set = 3, binding = 4, rgba32f) uniform image2D accum;
layout(set = 3, binding = 5, rgba32f) uniform image2D sum_total;
layout(set = 3, binding = 6, rgba32f) uniform image2D weight_total;
layout(set = 3, binding = 7, rgba32f) uniform image2D absorbed_total;

layout(push_constant) uniform Push {
    float weight;  // 1 / passes
    uint msaa;
    uint alpha_correction;  // 0 none, 1 per channel (depth-based), 2 stochastic (oit.rs CORRECTION_*)
    uint finish;   // 1: after the last pass, add the (corrected) layer sum
} pc;

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(p, imageSize(accum)))) return;
    if (pc.finish != 0u) {
        vec3 sum = imageLoad(sum_total, p).rgb;
        if (pc.alpha_correction != 0u) {
            vec3 w = imageLoad(weight_total, p).rgb;
            vec3 absorbed = imageLoad(absorbed_total, p).rgb;
            // No weight: no transparent fragment reached the pixel, so nothing was absorbed either.
            for (int c = 0; c < 3; ++c) sum[c] = w[c] > 0.0 ? sum[c] * absorbed[c] / w[c] : sum[c];
        }
        imageStore(accum, p, imageLoad(accum, p) + vec4(sum, 0.0));
        return;
    }
    vec3 behind = vec3(0.0), sum = vec3(0.0), w = vec3(0.0), absorbed = vec3(0.0);
    for (uint s = 0u; s < pc.msaa; ++s) {
        vec4 t = FETCH(total_transmittance, p, s);
        vec4 layer = FETCH(layer_sum, p, s);
        behind += FETCH(opaque_color, p, s).rgb * t.rgb;
        sum += layer.rgb;
        if (pc.alpha_correction == 2u) {
            w += vec3(layer.a);
            absorbed += vec3(1.0 - t.a);
        } else {
            w += FETCH(layer_weight, p, s).rgb;
            absorbed += 1.0 - t.rgb;
        }
    }
    float k = pc.weight / float(pc.msaa);
    imageStore(accum, p, imageLoad(accum, p) + vec4(k * behind, pc.weight));
    imageStore(sum_total, p, imageLoad(sum_total, p) + vec4(k * sum, 0.0));
    imageStore(weight_total, p, imageLoad(weight_total, p) + vec4(k * w, 0.0));
    imageStore(absorbed_total, p, imageLoad(absorbed_total, p) + vec4(k * absorbed, 0.0));
}
