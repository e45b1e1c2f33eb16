// Decoupled shading (Ragan-Kelley et al. 2011) in the shading pass: the GLSL mirror of
// engine/src/mirror/decoupled.rs (which explains the mapping), operation for operation, and the memoization
// cache. A sample's key is (its triangle in the frame's numbering, the side its ray sees, the
// lens-centre pixel cell of its surface point at mid-shutter); the key's value is the radiance at the
// key's shading point, a function of the key alone — so the cache below may miss, evict, race and
// re-shade, and the image stays what the reference's ReferenceShading::Decoupled computes.
//
// The cache: pc.cache_entries direct-mapped entries (slot = a hash of the key modulo the size; a new
// key evicts the entry's old one), shared by every invocation of every shading dispatch of the frame,
// cleared at its start. No invocation ever waits: an entry is a seqlock — a writer takes the key word
// (atomicCompSwap to DC_LOCKED), bumps the sequence to odd, writes the value, bumps it to even and
// stores its key; a reader keeps a value only if the key matched and the sequence was even and
// unchanged around its read. A reader that finds the entry locked, or a writer that loses the race for
// it, just shades (and does not store). Every access of an entry is an atomic operation, and the
// protocol relies on their order: llvmpipe's atomics are sequentially consistent, so this is exact
// there; a GPU port needs acquire/release semantics (GL_KHR_memory_scope_semantics), not done. (No
// memoryBarrierBuffer(): on llvmpipe a barrier in this function corrupted unrelated lanes' results.)
//
// The deferred mode (Liktor & Dachsbacher 2012; --shading decoupled-deferred), in four dispatches per
// object and pass, pc.decoupled_phase:
//   DC_PHASE_ALLOCATE (per pixel): each of the object's samples finds its key in a global hash table
//     of pc.cache_entries entries (open addressing, linear probing over at most DC_PROBES entries,
//     claimed by atomicCompSwap of the key word; nothing is ever evicted within a frame). The sample
//     that claims an entry writes the key's shading point (its barycentrics) there and appends the
//     entry to the queue of new shading points. Each sample's entry goes to the compact G-buffer
//     (DeferredRefs: one uint per sample of the pass); a sample without a key, or whose key found no
//     room within DC_PROBES entries (the overflow), gets DC_SHADE_HERE.
//   DC_PHASE_ARGS (one invocation): the queue's new points since the last shading become the next
//     dispatch's range and indirect arguments.
//   DC_PHASE_SHADE (indirect, one invocation per new point): shades it, stores its radiance.
//   DC_PHASE_RESOLVE (per pixel): each sample adds its entry's radiance; a DC_SHADE_HERE sample is
//     shaded on the spot (its key's shading point, or its own hit without a key) — the overflow's
//     fallback costs time, never a pixel.
// The table lives for the frame, so a key seen in an earlier pass is not shaded again. No invocation
// waits for another: the entry's radiance is read only after the barrier behind DC_PHASE_SHADE.
// Needs shade.glsl (shade_at, shade_hit, sample_at_time, the Counters block) and shade_decoupled.comp's
// push constants (DecoupledPush).
#ifndef SHUTTER_DECOUPLED_GLSL
#define SHUTTER_DECOUPLED_GLSL

struct CacheEntry {
    uint64_t key;  // 0: empty; DC_LOCKED: being written (memoization cache); else the key of the value
    uint seq;      // memoization cache: even when the value is whole; deferred: the point's w.x bits
    uint r, g, b;  // the value: radiance, float bits
    uint wy, wz;   // deferred: the shading point's barycentrics w.y, w.z (float bits)
};  // 32 bytes (CACHE_ENTRY_BYTES)
layout(set = 3, binding = 8, std430) buffer DecoupledCache { CacheEntry entries[]; } cache;
// The deferred mode's queue of new shading points: its length, how many were shaded, the range the
// current DC_PHASE_SHADE dispatch shades, its indirect arguments (at byte 16: DEFERRED_ARGS_OFFSET),
// then the entries. Holds pc.cache_entries slots: an entry is claimed once per frame.
layout(set = 3, binding = 10, std430) buffer DeferredQueue {
    uint count;
    uint shaded;
    uint first;
    uint end;
    uint groups_x, groups_y, groups_z;
    uint pad;
    uint slots[];
} queue;
// The compact G-buffer: per sample of the pass (visibility_index), its entry or DC_SHADE_HERE.
layout(set = 3, binding = 11, std430) buffer DeferredRefs { uint refs[]; };

const uint DC_PHASE_MEMO = 0u;  // the memoization cache (--shading decoupled)
const uint DC_PHASE_ALLOCATE = 1u;
const uint DC_PHASE_ARGS = 2u;
const uint DC_PHASE_SHADE = 3u;
const uint DC_PHASE_RESOLVE = 4u;
const uint DC_SHADE_HERE = 0xffffffffu;
const uint DC_PROBES = 16u;  // decoupled::DEFERRED_PROBES
const uint DC_SHADE_GROUP = 64u;  // DC_PHASE_SHADE invocations per workgroup (8 x 8)
// Every triangle's grid, in the frame's numbering (decoupled::object_grids): its axis, then the cell's
// size along and across it, pixels (the pixel grid: (1, 0), 1, 1).
layout(set = 3, binding = 9, std430) readonly buffer DecoupledGrids { vec4 decoupled_grids[]; };

const uint64_t DC_LOCKED = 0xffffffffffffffffUL;
const float DC_CELL_RANGE = 32767.0;  // decoupled::CELL_RANGE

// decoupled::clamp_to_triangle: the barycentrics of the point of (a, b, c) nearest to the plane point
// with barycentrics w (Ericson §5.1.5).
vec3 dc_clamp_to_triangle(vec3 a, vec3 b, vec3 c, vec3 w) {
    if (w.x >= 0.0 && w.y >= 0.0 && w.z >= 0.0) return w;
    vec3 q = w.x * a + w.y * b + w.z * c;
    vec3 ab = b - a, ac = c - a, ap = q - a;
    float d1 = dot(ab, ap), d2 = dot(ac, ap);
    if (d1 <= 0.0 && d2 <= 0.0) return vec3(1.0, 0.0, 0.0);
    vec3 bp = q - b;
    float d3 = dot(ab, bp), d4 = dot(ac, bp);
    if (d3 >= 0.0 && d4 <= d3) return vec3(0.0, 1.0, 0.0);
    float vc = d1 * d4 - d3 * d2;
    if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) {
        float v = d1 / (d1 - d3);
        return vec3(1.0 - v, v, 0.0);
    }
    vec3 cp = q - c;
    float d5 = dot(ab, cp), d6 = dot(ac, cp);
    if (d6 >= 0.0 && d5 <= d6) return vec3(0.0, 0.0, 1.0);
    float vb = d5 * d2 - d1 * d6;
    if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) {
        float t = d2 / (d2 - d6);
        return vec3(1.0 - t, 0.0, t);
    }
    float va = d3 * d6 - d5 * d4;
    if (va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0) {
        float t = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return vec3(0.0, 1.0 - t, t);
    }
    float denom = 1.0 / (va + vb + vc);
    float v = vb * denom, t = vc * denom;
    return vec3(1.0 - v - t, v, t);
}

// Intrinsics::project at the lens centre, pixels.
vec2 dc_project(vec3 p) {
    precise float z = -p.z;
    precise vec2 q = p.xy / z;
    precise vec2 px = vec2(0.5 * view.viewport.x + view.viewport.z * q.x, 0.5 * view.viewport.y - view.viewport.z * q.y);
    return px;
}

// decoupled::to_grid and from_grid: a screen point in grid cells and back, grid g = (axis, along, across).
vec2 dc_to_grid(vec4 g, vec2 q) {
    vec2 perp = vec2(-g.y, g.x);
    return vec2(dot(q, g.xy) / g.z, dot(q, perp) / g.w);
}

vec2 dc_from_grid(vec4 g, vec2 c) {
    vec2 perp = vec2(-g.y, g.x);
    return g.xy * (c.x * g.z) + perp * (c.y * g.w);
}

// decoupled::shading_point: false for a sample without a key (shade its own hit); else its cell in grid
// `grid` and the barycentrics of its key's shading point on the mid-shutter triangle (ma, mb, mc).
bool dc_shading_point(vec3 ma, vec3 mb, vec3 mc, vec3 w, vec4 grid, out ivec2 cell, out vec3 wc) {
    cell = ivec2(0);
    wc = w;
    vec3 point = w.x * ma + w.y * mb + w.z * mc;
    if (!(-point.z > 0.0)) return false;
    vec2 c = floor(dc_to_grid(grid, dc_project(point)));
    if (!(abs(c.x) < DC_CELL_RANGE && abs(c.y) < DC_CELL_RANGE)) return false;
    vec3 o, d;
    primary_ray(dc_from_grid(grid, c + vec2(0.5)), vec2(0.0), o, d);
    bool ok;
    vec3 b = plane_barycentrics(ma, mb, mc, o, d, ok);
    if (!ok) return false;
    vec3 at = b.x * ma + b.y * mb + b.z * mc;
    if (!(-at.z > 0.0)) return false;
    cell = ivec2(c);
    wc = dc_clamp_to_triangle(ma, mb, mc, b);
    return true;
}

uint64_t dc_key(uint payload, ivec2 cell) {
    uint cells = uint(cell.x + 32768) & 0xffffu | (uint(cell.y + 32768) & 0xffffu) << 16;
    return uint64_t(payload) << 32 | uint64_t(cells);
}

// A 64-bit key to a slot: both halves through an integer mix (PCG's output permutation style).
uint dc_slot(uint64_t key) {
    uint h = uint(key) * 0x9e3779b1u ^ uint(key >> 32) * 0x85ebca77u;
    h ^= h >> 16;
    h *= 0x7feb352du;
    h ^= h >> 15;
    h *= 0x846ca68bu;
    h ^= h >> 16;
    return h % pc.cache_entries;
}

bool dc_read(uint slot, uint64_t key, out vec3 v) {
    uint s1 = atomicOr(cache.entries[slot].seq, 0u);
    uint64_t k1 = atomicOr(cache.entries[slot].key, 0UL);
    v = vec3(uintBitsToFloat(atomicOr(cache.entries[slot].r, 0u)), uintBitsToFloat(atomicOr(cache.entries[slot].g, 0u)),
             uintBitsToFloat(atomicOr(cache.entries[slot].b, 0u)));
    uint s2 = atomicOr(cache.entries[slot].seq, 0u);
    uint64_t k2 = atomicOr(cache.entries[slot].key, 0UL);
    return k1 == key && k2 == key && s1 == s2 && (s1 & 1u) == 0u;
}

// Stores v for key unless another invocation holds the entry; counts evictions and lost races.
void dc_write(uint slot, uint64_t key, vec3 v) {
    uint64_t old = atomicOr(cache.entries[slot].key, 0UL);
    if (old == DC_LOCKED || atomicCompSwap(cache.entries[slot].key, old, DC_LOCKED) != old) {
#ifdef INSTRUMENTED
        atomicAdd(counters.cache_busy, 1u);
#endif
        return;
    }
    atomicAdd(cache.entries[slot].seq, 1u);
    atomicExchange(cache.entries[slot].r, floatBitsToUint(v.r));
    atomicExchange(cache.entries[slot].g, floatBitsToUint(v.g));
    atomicExchange(cache.entries[slot].b, floatBitsToUint(v.b));
    atomicAdd(cache.entries[slot].seq, 1u);
    atomicExchange(cache.entries[slot].key, key);
#ifdef INSTRUMENTED
    if (old != 0UL && old != key) atomicAdd(counters.cache_evictions, 1u);
#endif
}

// Where a sample of this object's triangle prim (visibility payload `payload`), hit as h, is shaded:
// false without a key (at its own hit); else its key, the mid-shutter triangle m (its ray from the lens
// centre to the key's shading point) and that point's barycentrics wc.
bool dc_locate(uint prim, uint payload, SampleHit h, out uint64_t key, out SampleHit m, out vec3 wc) {
    float z;
    vec3 w;
    if (!sample_hit(h.a, h.b, h.c, h.ro, h.rd, z, w)) {
        bool ok;
        w = plane_barycentrics(h.a, h.b, h.c, h.ro, h.rd, ok);
    }
    m = sample_at_time(prim, 0.5);
    ivec2 cell;
    vec4 grid = decoupled_grids[pc.shade.triangle_base + prim];
    bool keyed = dc_shading_point(m.a, m.b, m.c, w, grid, cell, wc);
    key = dc_key(payload, cell);
    // From the lens centre at mid-shutter.
    m.rd = normalize(wc.x * m.a + wc.y * m.b + wc.z * m.c);
    return keyed;
}

// Phase 1 of a sample (shade_decoupled.comp): its key's value from the cache, if there (true).
bool decoupled_lookup(uint prim, uint payload, SampleHit h, out vec3 v) {
    v = vec3(0.0);
    uint64_t key;
    SampleHit m;
    vec3 wc;
    if (!dc_locate(prim, payload, h, key, m, wc)) return false;
#ifdef INSTRUMENTED
    atomicAdd(counters.cache_lookups, 1u);
#endif
    bool hit = dc_read(dc_slot(key), key, v);
#ifdef INSTRUMENTED
    if (hit) atomicAdd(counters.cache_hits, 1u);
#endif
    return hit;
}

// Phase 2, for a sample phase 1 missed: its key's value if another sample stored it meanwhile (the
// pixel's own earlier ones included: a hit, counted against phase 1's lookup), else shades its key's
// shading point (on the side the sample saw) and stores it; without a key, shades its own hit. In the
// deferred mode's DC_PHASE_RESOLVE: a sample the table had no entry for, shaded on the spot.
vec3 decoupled_shade(uint prim, uint payload, SampleHit h) {
    uint64_t key;
    SampleHit m;
    vec3 wc;
    bool keyed = dc_locate(prim, payload, h, key, m, wc);
    bool memo = pc.decoupled_phase == DC_PHASE_MEMO;
    uint slot = dc_slot(key);
    vec3 v;
    if (memo && keyed && dc_read(slot, key, v)) {
#ifdef INSTRUMENTED
        atomicAdd(counters.cache_hits, 1u);
#endif
        return v;
    }
#ifdef INSTRUMENTED
    atomicAdd(counters.shading_invocations, 1u);
#endif
    if (!keyed) return shade_hit(prim, h);
    v = shade_at(prim, m, wc, (payload & 1u) != 0u);
    if (memo) dc_write(slot, key, v);
    return v;
}

// DC_PHASE_ALLOCATE for one sample: its key's entry in the hash table (claimed, with its shading
// point, and queued when new), or DC_SHADE_HERE without a key or room.
uint deferred_allocate(uint prim, uint payload, SampleHit h) {
    uint64_t key;
    SampleHit m;
    vec3 wc;
    if (!dc_locate(prim, payload, h, key, m, wc)) return DC_SHADE_HERE;
#ifdef INSTRUMENTED
    atomicAdd(counters.cache_lookups, 1u);
#endif
    uint slot = dc_slot(key);
    uint probes = min(DC_PROBES, pc.cache_entries);
    for (uint p = 0u; p < probes; p++) {
        uint s = (slot + p) % pc.cache_entries;
        uint64_t old = atomicCompSwap(cache.entries[s].key, 0UL, key);
        if (old == 0UL) {
            cache.entries[s].seq = floatBitsToUint(wc.x);
            cache.entries[s].wy = floatBitsToUint(wc.y);
            cache.entries[s].wz = floatBitsToUint(wc.z);
            queue.slots[atomicAdd(queue.count, 1u)] = s;
            return s;
        }
        if (old == key) {
#ifdef INSTRUMENTED
            atomicAdd(counters.cache_hits, 1u);
#endif
            return s;
        }
    }
#ifdef INSTRUMENTED
    atomicAdd(counters.cache_overflows, 1u);
#endif
    return DC_SHADE_HERE;
}

// DC_PHASE_ARGS: the points queued since the last DC_PHASE_SHADE become its range and arguments.
void deferred_args() {
    if (gl_LocalInvocationIndex != 0u) return;
    uint n = queue.count - queue.shaded;
    queue.first = queue.shaded;
    queue.end = queue.count;
    queue.shaded = queue.count;
    queue.groups_x = (n + DC_SHADE_GROUP - 1u) / DC_SHADE_GROUP;
    queue.groups_y = 1u;
    queue.groups_z = 1u;
}

// DC_PHASE_SHADE: one new shading point of this object, shaded at mid-shutter from the lens centre on
// the side its key names; its radiance stored in its entry.
void deferred_shade_point() {
    uint i = queue.first + gl_WorkGroupID.x * DC_SHADE_GROUP + gl_LocalInvocationIndex;
    if (i >= queue.end) return;
    uint s = queue.slots[i];
    uint64_t key = cache.entries[s].key;
    uint payload = uint(key >> 32);
    uint prim = (payload >> 1) - pc.shade.triangle_base;
    vec3 wc = vec3(uintBitsToFloat(cache.entries[s].seq), uintBitsToFloat(cache.entries[s].wy),
                   uintBitsToFloat(cache.entries[s].wz));
    SampleHit m = sample_at_time(prim, 0.5);
    m.rd = normalize(wc.x * m.a + wc.y * m.b + wc.z * m.c);
    vec3 v = shade_at(prim, m, wc, (payload & 1u) != 0u);
    cache.entries[s].r = floatBitsToUint(v.r);
    cache.entries[s].g = floatBitsToUint(v.g);
    cache.entries[s].b = floatBitsToUint(v.b);
#ifdef INSTRUMENTED
    atomicAdd(counters.shading_invocations, 1u);
#endif
}

// DC_PHASE_RESOLVE for a sample with entry `ref` (not DC_SHADE_HERE): its radiance.
vec3 deferred_value(uint ref) {
    return vec3(uintBitsToFloat(cache.entries[ref].r), uintBitsToFloat(cache.entries[ref].g),
                uintBitsToFloat(cache.entries[ref].b));
}

#endif
