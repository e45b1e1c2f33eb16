// Emission of a convex screen-space bound as a triangle strip, dilated by the box [-h, h]^2 (Minkowski
// sum). Mirrors bounds::dilate_box. The including stage defines where strips go, before including this:
//   void emit_ndc(vec2 ndc)  -- one strip vertex in normalized device coordinates
//   void end_strip()         -- the strip is complete
// (stochastic.geom emits them as geometry-shader output; expand.comp, the compute-expanded hull,
// writes them to a buffer as triangles.)
#ifndef SHUTTER_EMIT_GLSL
#define SHUTTER_EMIT_GLSL
#include "stochastic/inside.glsl"
#include "stochastic/bound_vertices.glsl"

// A sample can lie anywhere in its pixel square; the rasterizer's sample points sit at fixed offsets.
// pc.dilate (bounds::dilation_px) covers every sample point of every pixel whose square meets the bound.
// Beyond this many viewports from the image the bound is replaced by the viewport (rasterizer precision).
const float MAX_EXTENT_VIEWPORTS = 4.0;

void emit_pixel(vec2 p) {
    emit_ndc(vec2(2.0 * p.x / view.viewport.x - 1.0, 2.0 * p.y / view.viewport.y - 1.0));
}

void emit_viewport() {
    vec2 size = view.viewport.xy;
    emit_pixel(vec2(0.0, 0.0));
    emit_pixel(vec2(size.x, 0.0));
    emit_pixel(vec2(0.0, size.y));
    emit_pixel(size);
    end_strip();
}

// Quadrant of a direction, counter-clockwise (positive-area orientation) from +x: the box corner
// (sign x, sign y) supports every direction in it.
int quadrant(vec2 n) {
    if (n.x > 0.0 && n.y >= 0.0) return 0;
    if (n.x <= 0.0 && n.y > 0.0) return 1;
    if (n.x < 0.0 && n.y <= 0.0) return 2;
    return 3;
}

vec2 box_corner(int q) {
    const vec2 c[4] = vec2[4](vec2(1.0, 1.0), vec2(-1.0, 1.0), vec2(-1.0, -1.0), vec2(1.0, -1.0));
    return c[q] * pc.dilate;
}

// Outward normal (unnormalised) of edge a -> b of a positive-area polygon.
vec2 outward(vec2 a, vec2 b) {
    vec2 e = b - a;
    return vec2(e.y, -e.x);
}

// Emits pts[first .. first + n) (convex, positive area, or a point / segment) dilated by the box, as a
// strip: the Minkowski sum's vertices in order (each input vertex followed by the box corners its
// normal cone sweeps), then zig-zagged. Returns false (emitting nothing) when a point is too far out.
bool emit_dilated(vec2 pts[BOUND_MAX_POINTS], int first, int n) {
    vec2 q[BOUND_MAX_POINTS + 4];
    int m = 0;
    if (n == 1) {
        for (int k = 0; k < 4; k++) q[m++] = pts[first] + box_corner(k);
    } else {
        for (int i = 0; i < n; i++) {
            vec2 prev = pts[first + (i + n - 1) % n];
            vec2 cur = pts[first + i];
            vec2 next = pts[first + (i + 1) % n];
            int qa = quadrant(outward(prev, cur));
            int qb = quadrant(outward(cur, next));
            q[m++] = cur + box_corner(qa);
            for (int k = 0; k < 4 && qa != qb; k++) {
                qa = (qa + 1) & 3;
                q[m++] = cur + box_corner(qa);
            }
        }
    }
    vec2 size = view.viewport.xy;
    float lim = MAX_EXTENT_VIEWPORTS * max(size.x, size.y);
    for (int i = 0; i < m; i++) {
        vec2 c = q[i] - 0.5 * size;
        if (!(abs(c.x) <= lim && abs(c.y) <= lim)) return false;
    }
    for (int k = 0; k < m; k++) {
        int idx = (k & 1) == 1 ? (k + 1) / 2 : (m - k / 2) % m;
        emit_pixel(q[idx]);
    }
    end_strip();
    return true;
}

// Emits compute_bound's result: nothing when culled, each piece dilated, or the whole viewport (the
// bound said so, or a piece reaches too far out to rasterize exactly).
void emit_bound(int pieces, vec2 pts[BOUND_MAX_POINTS], int piece_len[BOUND_MAX_PIECES]) {
    if (pieces == 0) return;
    if (pieces < 0) {
        emit_viewport();
        return;
    }
    int first = 0;
    for (int k = 0; k < pieces; k++) {
        if (!emit_dilated(pts, first, piece_len[k])) {
            emit_viewport();
            return;
        }
        first += piece_len[k];
    }
}

#endif
