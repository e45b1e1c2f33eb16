// The one shading model, GLSL mirror of engine/src/shading.rs (see there for the formula).
#ifndef SHUTTER_SHADING_GLSL
#define SHUTTER_SHADING_GLSL
#include "common/frame.glsl"
#ifdef SHADOWS
#include "common/shadow.glsl"
#endif

float specular_exponent(float roughness) {
    float r = max(roughness, 1e-3);
    return clamp(2.0 / (r * r) - 2.0, 1.0, 1.0e4);
}

// The spot cone's falloff at the cosine of the angle off its axis (shading::spot_falloff): 1 inside
// the inner cone, 0 outside the outer, a smoothstep of the cosine between.
float spot_falloff(float cos_angle, float cos_inner, float cos_outer) {
    if (cos_angle >= cos_inner) return 1.0;
    if (cos_angle <= cos_outer) return 0.0;
    float x = (cos_angle - cos_outer) / (cos_inner - cos_outer);
    return x * x * (3.0 - 2.0 * x);
}

// Radiance at camera-space `pos` with unit normal `n` facing the viewer and unit `to_eye` towards the
// lens sample, lights interpolated to shutter time t. With SHADOWS, each light is attenuated by its
// shadow map at the receiver the caller set in `shadow_receiver`.
vec3 shade(vec3 pos, vec3 n, vec3 to_eye, vec3 albedo, float specular, float roughness, float t) {
    float n_exp = specular_exponent(roughness);
    float norm = (n_exp + 8.0) / (8.0 * 3.14159265358979);
    vec3 diffuse = world.ambient.rgb;
    vec3 spec = vec3(0.0);
    int count = int(view.viewport.w);
    for (int i = 0; i < count; ++i) {
        Light light = view.lights[i];
        vec3 a = mix(light.at_open.xyz, light.at_close.xyz, t);
        vec3 l;
        vec3 e = light.color.rgb;
        if (light.at_open.w == LIGHT_DIRECTIONAL) {
            float len = length(a);
            l = len > 0.0 ? a / len : vec3(0.0);
        } else if (light.at_open.w == LIGHT_SPOT) {
            vec3 d = a - pos;
            float d2 = max(dot(d, d), 1e-8);
            l = d / sqrt(d2);
            vec3 axis = mix(light.spot_open.xyz, light.spot_close.xyz, t);
            float axis_len = length(axis);
            axis = axis_len > 0.0 ? axis / axis_len : vec3(0.0);
            e = e * spot_falloff(-dot(l, axis), light.spot_open.w, light.spot_close.w) / d2;
        } else {
            vec3 d = a - pos;
            float d2 = max(dot(d, d), 1e-8);
            l = d / sqrt(d2);
            e /= d2;
        }
        float ndl = max(dot(n, l), 0.0);
        if (ndl <= 0.0) continue;
#ifdef SHADOWS
        e *= shadow_light(i);  // the receiver's transmittance towards light i (common/shadow.glsl)
#endif
        diffuse += e * ndl;
        if (specular > 0.0) {
            vec3 h = l + to_eye;
            float hl = length(h);
            h = hl > 0.0 ? h / hl : vec3(0.0);
            spec += e * (norm * pow(max(dot(n, h), 0.0), n_exp) * ndl);
        }
    }
    return albedo * diffuse + specular * spec;
}

#endif
