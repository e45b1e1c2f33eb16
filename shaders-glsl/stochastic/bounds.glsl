// Screen-space bounds of stochastic rasterization: the GLSL mirror of bounds::bound() in
// engine/src/mirror/bounds/ (mod.rs: hard cases, convex hull, box; shapes.rs: the thesis' shapes, our
// reconstruction; hull.rs: monotone chain). The CPU code is the specification: read its docs for the
// shapes and why each is conservative. Same formulas in the same order, in float; differences:
// * MovingTriangle::is_degenerate runs in f64 on the CPU, in float here with the same relative
//   threshold DEGENERATE_EPS = 1e-12: float rounding of an exactly degenerate triangle's area vector is
//   ~4e-7 L^2, so here such triangles usually get a (conservative, useless) bound where the CPU culls
//   them. A higher threshold would cull visible slivers (a needle reaching towards the near plane can be
//   far wider on screen than its relative area suggests), so this errs on the conservative side;
// * the mid triangle's degenerate test and the hull's orientation test are f64 on the CPU (the latter
//   with an exact sign); see bound_orient_ for the float version;
// * GLSL division, normalize and dot may round differently (FMA contraction, reciprocals).
// So compare with the CPU up to ~1e-3 px + 1e-5 relative, and expect borderline branch decisions
// (degenerate, still, adaptive thresholds, wedge slab H > 0, nearly collinear hull vertices) to differ
// now and then. Pixel coordinates: x right, y down; pieces are CCW (positive shoelace area in pixel
// coordinates, i.e. clockwise on screen).
#ifndef SHUTTER_STOCHASTIC_BOUNDS_GLSL
#define SHUTTER_STOCHASTIC_BOUNDS_GLSL
#include "common/frame.glsl"

// BoundKind::id() (engine/src/mirror/bounds/mod.rs), the `kind` argument of compute_bound.
#define BOUND_BBOX 0
#define BOUND_2D_HEXAGON 1
#define BOUND_PARALLEL_EDGE_TRIANGLE 2
#define BOUND_VARIABLE_RADIUS_TRIANGLE 3
#define BOUND_3D_HEXAGON 4
#define BOUND_WEDGE 5
#define BOUND_REDUCED_WEDGE 6
#define BOUND_CONVEX_HULL 7
#define BOUND_ADAPTIVE 8

#define BOUND_MAX_POINTS 48
#define BOUND_MAX_PIECES 4

// Constants of engine/src/mirror/bounds/ (checked against the CPU values by a test in bounds/tests.rs).
const float BOUND_FLT_EPSILON = 1.1920929e-7;
const float BOUND_RADIUS_ROUND_UP = 1.0000005;  // RADIUS_ROUND_UP = 1 + 4 eps
const float BOUND_DEGENERATE_EPS = 1e-12;       // DEGENERATE_EPS (is_degenerate)
const float BOUND_MID_DEGENERATE_EPS = 1e-5;    // MID_DEGENERATE_EPS
const float BOUND_STILL_EPS_PX = 0.001;         // STILL_EPS_PX
const float BOUND_VOLUME_SLIVER = 0.01;         // volumes::VOLUME_SLIVER
const float BOUND_CLIP_PAD_EPS = 7.6293945e-6;  // CLIP_PAD_EPS = 64 eps
const float BOUND_ADAPTIVE_MOTION_MIN_PX = 0.5; // ADAPTIVE_MOTION_MIN_PX
const float BOUND_ADAPTIVE_SMALL_BLUR = 0.25;   // ADAPTIVE_SMALL_BLUR
// circumscribed_corners(8) and circumscribed_corners(6), as the CPU's f32 cos/sin computed them.
const vec2 BOUND_OCTAGON[8] = vec2[8](
    vec2(1.0, 0.4142136), vec2(0.41421357, 1.0), vec2(-0.41421366, 1.0), vec2(-1.0000001, 0.4142134),
    vec2(-1.0, -0.41421357), vec2(-0.41421324, -1.0000001), vec2(0.41421375, -0.99999994),
    vec2(1.0, -0.41421357));
const vec2 BOUND_HEXAGON[6] = vec2[6](
    vec2(0.99999994, 0.57735026), vec2(-5.0473563e-8, 1.1547005), vec2(-1.0000001, 0.5773501),
    vec2(-0.9999998, -0.57735044), vec2(1.3769665e-8, -1.1547005), vec2(1.0000001, -0.57734996));

// Private state of one compute_bound call (globals avoid copying arrays through function arguments).
vec2 bound_c_[6];                   // EndDiscs::centre: pinhole projections (pixels)
float bound_r_[6];                  // EndDiscs::radius: |phi(z)| * BOUND_RADIUS_ROUND_UP
vec2 bound_lc_[6];                  // centres relative to the mid triangle's centroid
vec2 bound_in_[BOUND_MAX_POINTS];   // candidate points of the piece being built
vec2 bound_out_[BOUND_MAX_POINTS];  // finished pieces, consecutive
int bound_out_n_;
int bound_pieces_;
int bound_piece_len_[BOUND_MAX_PIECES];
// MidTriangle: origin, CCW local vertices, original vertex per slot, edge directions/normals/lengths.
vec2 bound_mo_;
vec2 bound_mp_[3];
int bound_mv_[3];
vec2 bound_md_[3];
vec2 bound_mn_[3];
float bound_ml_[3];
float bound_ma_;  // twice the area

// orient(): cross(b - a, c - a), > 0 for a counter-clockwise turn. The CPU evaluates it in f64 (an
// exact sign for f32 inputs); in float the cross product is taken at the vertex opposite the longest
// edge, so that for two nearly coincident points (exact Sterbenz differences) and a far one the sign
// stays reliable. Taking it at `a` regardless lets the monotone chain keep a reflex vertex next to a
// tiny edge, whose half-plane then cuts the polygon far away.
// Aperture radius the bound assumes: 0 in the motion-only permutation (NO_DEFOCUS), whose inside test
// traces every sample from the lens centre.
float bound_aperture_() {
#ifdef NO_DEFOCUS
    return 0.0;
#else
    return view.lens.x;
#endif
}

float bound_orient_(vec2 a, vec2 b, vec2 c) {
    vec2 ab = b - a, bc = c - b, ca = a - c;
    float lab = dot(ab, ab), lbc = dot(bc, bc), lca = dot(ca, ca);
    vec2 u, v;
    if (lab >= lbc && lab >= lca) {
        u = a - c;  // pivot c
        v = b - c;
    } else if (lbc >= lca) {
        u = ab;  // pivot a
        v = c - a;
    } else {
        u = bc;  // pivot b
        v = a - b;
    }
    return u.x * v.y - u.y * v.x;
}

bool bound_finite_(vec2 p) {
    return !(any(isnan(p)) || any(isinf(p)));
}

// MovingTriangle::is_degenerate: the area vector (1-t)^2 X0 + t(1-t) Xm + t^2 X1 is small at every t.
bool bound_is_degenerate_(vec3 v[6]) {
    vec3 a0 = v[1] - v[0], b0 = v[2] - v[0];
    vec3 a1 = v[4] - v[3], b1 = v[5] - v[3];
    vec3 x0 = cross(a0, b0);
    vec3 x1 = cross(a1, b1);
    vec3 xm = cross(a0, b1) + cross(a1, b0);
    float l2 = max(max(max(0.0, dot(a0, a0)), dot(b0, b0)), max(dot(a1, a1), dot(b1, b1)));
    float eps = BOUND_DEGENERATE_EPS * l2;
    return length(x0) <= eps && length(x1) <= eps && length(xm) <= eps;
}

// convex_hull() (Andrew's monotone chain) of bound_in_[0, n), appended to bound_out_ as one piece.
// Callers pass finite points only. The input is sorted in place.
void bound_emit_hull_(int n) {
    for (int i = 1; i < n; ++i) {
        vec2 p = bound_in_[i];
        int j = i - 1;
        while (j >= 0 && (bound_in_[j].x > p.x || (bound_in_[j].x == p.x && bound_in_[j].y > p.y))) {
            bound_in_[j + 1] = bound_in_[j];
            --j;
        }
        bound_in_[j + 1] = p;
    }
    int m = 0;
    for (int i = 0; i < n; ++i) {
        if (m == 0 || bound_in_[i] != bound_in_[m - 1]) {
            bound_in_[m] = bound_in_[i];
            ++m;
        }
    }
    int base = bound_out_n_;
    int h = 0;
    if (m <= 2) {
        for (int i = 0; i < m; ++i) bound_out_[base + i] = bound_in_[i];
        h = m;
    } else {
        vec2 st[2 * BOUND_MAX_POINTS];
        for (int i = 0; i < m; ++i) {  // lower chain, left to right
            vec2 p = bound_in_[i];
            while (h >= 2 && bound_orient_(st[h - 2], st[h - 1], p) <= 0.0) --h;
            st[h] = p;
            ++h;
        }
        int lower_len = h + 1;
        for (int i = m - 2; i >= 0; --i) {  // upper chain, right to left
            vec2 p = bound_in_[i];
            while (h >= lower_len && bound_orient_(st[h - 2], st[h - 1], p) <= 0.0) --h;
            st[h] = p;
            ++h;
        }
        --h;  // the first point again
        if (h == 2 && st[0] == st[1]) h = 1;
        h = min(h, BOUND_MAX_POINTS - base);
        for (int i = 0; i < h; ++i) bound_out_[base + i] = st[i];
    }
    bound_piece_len_[bound_pieces_] = h;
    ++bound_pieces_;
    bound_out_n_ += h;
}

// shapes.rs `finish`: local bound_in_[0, n) back to pixels, then the hull; false if not finite.
bool bound_finish_(int n) {
    for (int i = 0; i < n; ++i) {
        bound_in_[i] = bound_in_[i] + bound_mo_;
        if (!bound_finite_(bound_in_[i])) return false;
    }
    bound_emit_hull_(n);
    return true;
}

// Local::support: h(n) = max_m (n . c_m + r_m), relative to the mid triangle's centroid.
float bound_support_(vec2 n) {
    float h = dot(n, bound_lc_[0]) + bound_r_[0];
    for (int m = 1; m < 6; ++m) h = max(h, dot(n, bound_lc_[m]) + bound_r_[m]);
    return h;
}

// shapes.rs `intersect`: lines n.x = h, walking along line a from its foot point.
vec2 bound_intersect_(vec2 na, float ha, vec2 nb, float hb) {
    vec2 foot = na * ha;
    vec2 along = vec2(-na.y, na.x);
    float t = (hb - dot(nb, foot)) / dot(nb, along);
    return foot + along * t;
}

// MidTriangle::new; false when degenerate.
bool bound_mid_triangle_() {
    vec2 pa[3];
    for (int i = 0; i < 3; ++i) pa[i] = (bound_c_[i] + bound_c_[i + 3]) * 0.5;
    bound_mo_ = (pa[0] + pa[1] + pa[2]) / 3.0;
    for (int i = 0; i < 3; ++i) bound_mp_[i] = pa[i] - bound_mo_;
    float area2 = bound_orient_(bound_mp_[0], bound_mp_[1], bound_mp_[2]);
    float l2 = 0.0;
    for (int i = 0; i < 3; ++i) {
        vec2 d = bound_mp_[(i + 1) % 3] - bound_mp_[i];
        l2 = max(l2, dot(d, d));
    }
    if (!(abs(area2) > BOUND_MID_DEGENERATE_EPS * l2)) return false;
    bound_mv_[0] = 0;
    bound_mv_[1] = 1;
    bound_mv_[2] = 2;
    if (area2 < 0.0) {
        vec2 t = bound_mp_[1];
        bound_mp_[1] = bound_mp_[2];
        bound_mp_[2] = t;
        bound_mv_[1] = 2;
        bound_mv_[2] = 1;
    }
    for (int i = 0; i < 3; ++i) {
        vec2 d = bound_mp_[(i + 1) % 3] - bound_mp_[i];
        bound_ml_[i] = length(d);
        bound_md_[i] = d / bound_ml_[i];
        bound_mn_[i] = vec2(bound_md_[i].y, -bound_md_[i].x);  // outward: right of the CCW direction
    }
    vec2 e1 = bound_mp_[1] - bound_mp_[0], e2 = bound_mp_[2] - bound_mp_[0];
    bound_ma_ = e1.x * e2.y - e1.y * e2.x;
    for (int m = 0; m < 6; ++m) bound_lc_[m] = bound_c_[m] - bound_mo_;
    return true;
}

// adaptive_kind_of (policy in shapes.rs).
int bound_adaptive_kind_(bool mid_ok) {
    if (!mid_ok) return BOUND_CONVEX_HULL;
    float rmax = 0.0;
    for (int m = 0; m < 6; ++m) rmax = max(rmax, bound_r_[m]);
    float motion = 0.0;
    for (int i = 0; i < 3; ++i) motion = max(motion, length(bound_c_[i + 3] - bound_c_[i]));
    if (motion > max(rmax, BOUND_ADAPTIVE_MOTION_MIN_PX)) return BOUND_CONVEX_HULL;
    float inradius = bound_ma_ / (bound_ml_[0] + bound_ml_[1] + bound_ml_[2]);
    if (rmax <= BOUND_ADAPTIVE_SMALL_BLUR * inradius) return BOUND_PARALLEL_EDGE_TRIANGLE;
    return BOUND_CONVEX_HULL;
}

// Corners of the triangle of three CCW lines (triangle_of): corner i = line i-1 meets line i.
void bound_triangle_of_(vec2 n[3], float h[3]) {
    for (int i = 0; i < 3; ++i) bound_in_[i] = bound_intersect_(n[(i + 2) % 3], h[(i + 2) % 3], n[i], h[i]);
}

// parallel_edge_triangle, hexagon_2d, variable_radius_triangle; false -> convex-hull fallback.
bool bound_triangle_shape_(int kind) {
    vec2 n[3];
    float h[3];
    for (int i = 0; i < 3; ++i) {
        n[i] = bound_mn_[i];
        h[i] = bound_support_(n[i]);
    }
    if (kind == BOUND_VARIABLE_RADIUS_TRIANGLE) {
        float big_r[3];
        for (int i = 0; i < 3; ++i) {
            big_r[i] = max(bound_r_[i], bound_r_[i + 3]) + 0.5 * length(bound_c_[i + 3] - bound_c_[i]);
        }
        vec2 t[3];
        for (int i = 0; i < 3; ++i) {
            float beta = (big_r[bound_mv_[i]] - big_r[bound_mv_[(i + 1) % 3]]) / bound_ml_[i];
            t[i] = abs(beta) >= 1.0 ? bound_mn_[i] : bound_mn_[i] * sqrt(1.0 - beta * beta) + bound_md_[i] * beta;
        }
        bool spans = true;
        for (int i = 0; i < 3; ++i) {
            vec2 a = t[i], b = t[(i + 1) % 3];
            spans = spans && a.x * b.y - a.y * b.x > 0.0;
        }
        if (spans) {  // otherwise diverging edges: keep the parallel-edge triangle
            for (int i = 0; i < 3; ++i) {
                n[i] = t[i];
                h[i] = bound_support_(n[i]);
            }
        }
    }
    bound_triangle_of_(n, h);
    if (kind != BOUND_2D_HEXAGON) return bound_finish_(3);
    vec2 corner[3] = vec2[3](bound_in_[0], bound_in_[1], bound_in_[2]);
    int k = 0;
    for (int i = 0; i < 3; ++i) {
        int a = (i + 2) % 3;
        vec2 s = n[a] + n[i];
        vec2 nv = s * (1.0 / length(s));
        float hv = bound_support_(nv);
        if (dot(nv, corner[i]) > hv) {
            bound_in_[k] = bound_intersect_(n[a], h[a], nv, hv);
            bound_in_[k + 1] = bound_intersect_(nv, hv, n[i], h[i]);
            k += 2;
        } else {
            bound_in_[k] = corner[i];
            k += 1;
        }
    }
    return bound_finish_(k);
}

// volumes.rs `prism` and bounds::volume_silhouette: the thesis' view-space prism (hexagonal, or the
// wedge's triangular one) around the discs of confusion of the still triangle t, its vertices' pinhole
// projections into bound_in_; returns their count, or 0 when there is none (a sliver, VOLUME_SLIVER) or
// it reaches the near plane (the caller falls back to the convex hull).
int bound_volume_(vec3 t[3], bool hexagon) {
    float A = bound_aperture_(), F = view.lens.y, near_z = view.lens.z;
    float W = view.viewport.x, H = view.viewport.y, s = view.viewport.z;
    vec3 n = cross(t[1] - t[0], t[2] - t[0]);
    float scale = max(max(length(t[1] - t[0]), length(t[2] - t[0])), length(t[2] - t[1]));
    float area2 = length(n);
    if (isnan(area2) || area2 <= BOUND_VOLUME_SLIVER * scale * scale) return 0;
    n = normalize(n);
    float r[3];
    for (int i = 0; i < 3; ++i) r[i] = A * abs(-t[i].z - F) / F * BOUND_RADIUS_ROUND_UP;
    // Outward in-plane edge normals (edge i -> j, the third vertex o inside).
    vec3 m[6];
    int lines = 3;
    for (int e = 0; e < 3; ++e) {
        int i = e, j = (e + 1) % 3, o = (e + 2) % 3;
        vec3 mm = normalize(cross(t[j] - t[i], n));
        if (dot(mm, t[o] - t[i]) > 0.0) mm = -mm;
        m[e] = mm;
    }
    if (hexagon) {
        // The corner edges: the mean direction of the two edge normals meeting at each vertex.
        vec3 p2[3] = vec3[3](m[2], m[0], m[1]), q2[3] = vec3[3](m[0], m[1], m[2]);
        for (int c = 0; c < 3; ++c) {
            vec3 sum = p2[c] + q2[c];
            float len = length(sum);
            if (len > 0.0 && !isinf(len) && !isnan(len)) m[lines++] = sum / len;
        }
    }
    vec3 centre = (t[0] + t[1] + t[2]) / 3.0;
    vec3 e1 = normalize(t[1] - t[0]);
    vec3 e2 = cross(n, e1);
    float rmax = max(max(r[0], r[1]), r[2]);
    float half_side = 4.0 * (scale + rmax) + 1e-6;
    // Sutherland-Hodgman from a big square: at most 4 + 6 vertices.
    vec2 poly[10], next[10];
    int count = 4;
    poly[0] = vec2(-half_side, -half_side);
    poly[1] = vec2(half_side, -half_side);
    poly[2] = vec2(half_side, half_side);
    poly[3] = vec2(-half_side, half_side);
    for (int l = 0; l < lines; ++l) {
        vec3 mm = m[l];
        float d = -1.0 / 0.0;
        for (int i = 0; i < 3; ++i) d = max(d, dot(mm, t[i]) + r[i] * sqrt(max(1.0 - mm.z * mm.z, 0.0)));
        float pad = 1e-5 * (abs(d) + scale + rmax);
        vec2 m2 = vec2(dot(mm, e1), dot(mm, e2));
        float d2 = d - dot(mm, centre) + pad;
        int k = 0;
        for (int i = 0; i < count; ++i) {
            vec2 p = poly[i], q = poly[(i + 1) % count];
            float fp = dot(m2, p) - d2, fq = dot(m2, q) - d2;
            if (fp <= 0.0 && k < 10) next[k++] = p;
            if (((fp < 0.0 && fq > 0.0) || (fp > 0.0 && fq < 0.0)) && k < 10) next[k++] = p + (q - p) * (fp / (fp - fq));
        }
        count = k;
        for (int i = 0; i < count; ++i) poly[i] = next[i];
        if (count == 0) return 0;
    }
    float off_z = sqrt(max(1.0 - n.z * n.z, 0.0));
    float lift = 0.0;
    for (int i = 0; i < 3; ++i) lift = max(lift, abs(dot(n, t[i] - centre)) + r[i] * off_z);
    lift = lift * BOUND_RADIUS_ROUND_UP + 1e-6 * (scale + rmax);
    int out_n = 0;
    for (int side = 0; side < 2; ++side) {
        float sgn = side == 0 ? -1.0 : 1.0;
        for (int i = 0; i < count; ++i) {
            vec3 p = centre + e1 * poly[i].x + e2 * poly[i].y + n * (sgn * lift);
            float z = -p.z;
            if (!(z > near_z)) return 0;
            vec2 q = vec2(0.5 * W + s * (p.x / z), 0.5 * H - s * (p.y / z));
            if (!bound_finite_(q)) return 0;
            bound_in_[out_n++] = q;
        }
    }
    return out_n;
}

// A rectangle as the single piece (ScreenBound::pieces order: min, (max.x, min.y), max, (min.x, max.y)).
int bound_box_(vec2 lo, vec2 hi) {
    bound_out_[0] = lo;
    bound_out_[1] = vec2(hi.x, lo.y);
    bound_out_[2] = hi;
    bound_out_[3] = vec2(lo.x, hi.y);
    bound_out_n_ = 4;
    bound_piece_len_[0] = 4;
    bound_pieces_ = 1;
    return 1;
}

// clip_and_box (engine/src/mirror/bounds/mod.rs): the end vertices' hull clipped to z >= z_clip, each point
// widened by its circle of confusion, boxed and clamped to the viewport. -1 when that is the viewport.
int bound_clip_and_box_(vec3 v[6], float z_clip) {
    float W = view.viewport.x, H = view.viewport.y, s = view.viewport.z;
    float A = bound_aperture_(), F = view.lens.y;
    if (!(z_clip > 0.0)) return -1;
    vec2 lo = vec2(1.0 / 0.0), hi = vec2(-1.0 / 0.0);
    for (int a = 0; a < 6; ++a) {
        for (int b = a; b < 6; ++b) {
            float za = -v[a].z, zb = -v[b].z;
            vec3 p;
            if (b == a) {
                if (!(za >= z_clip)) continue;
                p = v[a];
            } else {
                if (!((za - z_clip) * (zb - z_clip) < 0.0)) continue;
                float t = (z_clip - za) / (zb - za);
                p = v[a] + (v[b] - v[a]) * t;
                p.z = -z_clip;
            }
            float z = -p.z;
            vec2 q = p.xy / z;
            vec2 c = vec2(0.5 * W + s * q.x, 0.5 * H - s * q.y);
            float r = abs(A * s * (1.0 / F - 1.0 / z)) * BOUND_RADIUS_ROUND_UP;
            lo = min(lo, c - vec2(r));
            hi = max(hi, c + vec2(r));
        }
    }
    if (!bound_finite_(lo) || !bound_finite_(hi)) return -1;
    vec2 m = max(abs(lo), abs(hi));
    float pad = BOUND_CLIP_PAD_EPS * max(m.x, m.y);
    lo = max(lo - vec2(pad), vec2(0.0));
    hi = min(hi + vec2(pad), vec2(W, H));
    if (lo.x > hi.x || lo.y > hi.y) return 0;
    if (lo == vec2(0.0) && hi == vec2(W, H)) return -1;
    return bound_box_(lo, hi);
}

int bound_compute_(int kind, vec3 v[6]) {
    bound_out_n_ = 0;
    bound_pieces_ = 0;
    // Hard cases, in bound()'s order.
    float amax = 0.0;
    for (int m = 0; m < 6; ++m) {
        if (any(isnan(v[m])) || any(isinf(v[m]))) return 0;
        vec3 a = abs(v[m]);
        amax = max(amax, max(max(a.x, a.y), a.z));
    }
    float W = view.viewport.x, H = view.viewport.y, s = view.viewport.z;
    float A = bound_aperture_(), F = view.lens.y, near_z = view.lens.z, far_z = view.lens.w;
    float margin = 8.0 * BOUND_FLT_EPSILON * amax;
    bool all_near = true, all_far = true, any_near = false;
    for (int m = 0; m < 6; ++m) {
        float z = -v[m].z;
        all_near = all_near && z < near_z - margin;
        all_far = all_far && z > far_z + margin;
        any_near = any_near || z <= near_z;
    }
    if (all_near || all_far || bound_is_degenerate_(v)) return 0;
    if (any_near) return bound_clip_and_box_(v, near_z - margin);
    // EndDiscs::new: Intrinsics::project(v, 0) and |circle_of_confusion_px| rounded up.
    for (int m = 0; m < 6; ++m) {
        float z = -v[m].z;
        vec2 q = v[m].xy / z;
        bound_c_[m] = vec2(0.5 * W + s * q.x, 0.5 * H - s * q.y);
        bound_r_[m] = abs(A * s * (1.0 / F - 1.0 / z)) * BOUND_RADIUS_ROUND_UP;
        if (!bound_finite_(bound_c_[m]) || isnan(bound_r_[m]) || isinf(bound_r_[m])) return -1;
    }
    // The thesis' volumes (still triangles, the prism in front of the near plane), else the hull.
    if (kind == BOUND_3D_HEXAGON || kind == BOUND_WEDGE || kind == BOUND_REDUCED_WEDGE) {
        if (v[0] == v[3] && v[1] == v[4] && v[2] == v[5]) {
            int n = bound_volume_(vec3[3](v[0], v[1], v[2]), kind == BOUND_3D_HEXAGON);
            if (n > 0) {
                bound_emit_hull_(n);
                return 1;
            }
        }
        kind = BOUND_CONVEX_HULL;
    }
    bool mid_ok = false;
    if (kind != BOUND_BBOX && kind != BOUND_CONVEX_HULL) {
        mid_ok = bound_mid_triangle_();
    }
    if (kind == BOUND_ADAPTIVE) kind = bound_adaptive_kind_(mid_ok);
    if (mid_ok) {
        bool built = false;
        if (kind == BOUND_PARALLEL_EDGE_TRIANGLE || kind == BOUND_2D_HEXAGON
            || kind == BOUND_VARIABLE_RADIUS_TRIANGLE) {
            built = bound_triangle_shape_(kind);
        }
        if (built) return bound_pieces_;
        bound_out_n_ = 0;
        bound_pieces_ = 0;
    }
    // Hull-based kinds and the fallback of the thesis shapes (disc_polygon_points).
    int n = 0;
    for (int m = 0; m < 6; ++m) {
        if (bound_r_[m] > 0.0) {
            for (int j = 0; j < 8; ++j) bound_in_[n + j] = bound_c_[m] + BOUND_OCTAGON[j] * bound_r_[m];
            n += 8;
        } else {
            bound_in_[n] = bound_c_[m];
            n += 1;
        }
    }
    for (int i = 0; i < n; ++i) {
        if (!bound_finite_(bound_in_[i])) return -1;
    }
    if (kind == BOUND_BBOX) {
        vec2 lo = bound_in_[0], hi = bound_in_[0];
        for (int i = 1; i < n; ++i) {
            lo = min(lo, bound_in_[i]);
            hi = max(hi, bound_in_[i]);
        }
        return bound_box_(lo, hi);
    }
    bound_emit_hull_(n);
    return 1;
}

// v: camera-space end vertices (open 0..2, close 3..5). Returns the number of convex pieces written
// (0 = culled, -1 = the whole viewport); piece k has piece_len[k] points, stored consecutively in pts,
// CCW (positive shoelace area in pixel coordinates). Mirrors bounds::bound() in engine/src/mirror/bounds/
// (ScreenBound::pieces() gives the CPU's pieces in this layout). Entries past the written points and
// pieces are left undefined. A piece may have 1 or 2 points (a point or segment) for a pinhole
// image that degenerates.
int compute_bound(uint kind, vec3 v[6], out vec2 pts[BOUND_MAX_POINTS], out int piece_len[BOUND_MAX_PIECES]) {
    int pieces = bound_compute_(int(kind), v);
    for (int i = 0; i < bound_out_n_; ++i) pts[i] = bound_out_[i];
    for (int i = 0; i < max(pieces, 0); ++i) piece_len[i] = bound_piece_len_[i];
    return pieces;
}

#endif
