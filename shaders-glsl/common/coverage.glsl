// Stochastic coverage with per-pixel stratified masks: the GLSL mirror of engine/src/transparency.rs
// (same 32-bit integer operations, so the GPU and the CPU reference make the same decision for the
// same (seed, pixel, sample, triangle)). Sample k of the pixel's S is covered by a surface of
// coverage alpha iff rank(k) < floor(alpha*S + u): exactly floor or ceil of alpha*S samples, each
// with probability alpha.
#ifndef SHUTTER_COVERAGE_GLSL
#define SHUTTER_COVERAGE_GLSL

uint coverage_hash32(uint x) {
    x ^= x >> 16;
    x *= 0x7feb352du;
    x ^= x >> 15;
    x *= 0x846ca68bu;
    return x ^ (x >> 16);
}

uint coverage_key(uint seed, uvec2 pixel, uint triangle) {
    uint h = coverage_hash32(triangle + seed);
    h = coverage_hash32(h ^ (pixel.x * 0x9e3779b9u));
    return coverage_hash32(h ^ (pixel.y * 0x85ebca6bu));
}

// alpha in 24-bit fixed point: scaling by 2^24 is exact, the conversion truncates (as the CPU).
uint coverage_alpha_fixed(float alpha) {
    return uint(clamp(alpha, 0.0, 1.0) * 16777216.0);
}

// floor(alpha * samples + u) with u the key's 24-bit uniform: a 24x32-bit product in 64 bits.
uint coverage_count(float alpha, uint samples, uint key) {
    uint u = coverage_hash32(key ^ 0x68e31da4u) >> 8;
    uint hi, lo, carry;
    umulExtended(coverage_alpha_fixed(alpha), samples, hi, lo);
    lo = uaddCarry(lo, u, carry);
    hi += carry;
    return (hi << 8) | (lo >> 24);
}

// Rank of sample k among `samples`: a keyed scramble inside the next power of two, cycle-walked back
// into range, then a keyed rotation.
uint coverage_rank(uint k, uint samples, uint key) {
    if (samples <= 1u) return 0u;
    uint mask = 0xffffffffu >> uint(31 - findMSB(samples - 1u));
    uint p0 = coverage_hash32(key ^ 0x1b873593u);
    uint p1 = coverage_hash32(key ^ 0xcc9e2d51u) | 1u;
    uint i = k % samples;
    do {
        i ^= p0;
        i &= mask;
        i = (i * p1) & mask;
        i ^= i >> 3;
        i = (i * 0x2c1b3c6du) & mask;
        i ^= i >> 7;
    } while (i >= samples);
    uint offset = coverage_hash32(key ^ 0x0d1ab7c5u) % samples;
    return (i + offset) % samples;
}

// The mask of `count` consecutive samples base, base+1, ... (bit j: sample base + j) that a surface
// with this key and coverage covers among the pixel's `samples`.
uint coverage_mask(uint key, float alpha, uint samples, uint base, uint count) {
    uint n = coverage_count(alpha, samples, key);
    uint mask = 0u;
    for (uint j = 0u; j < count; ++j) {
        if (coverage_rank(base + j, samples, key) < n) mask |= 1u << j;
    }
    return mask;
}

#endif
