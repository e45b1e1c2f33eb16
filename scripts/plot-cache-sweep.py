#!/usr/bin/env python3
"""The cache-size sweep of docs/DECOUPLED.md as a plot: shading invocations against cache (or hash
table) entries, log-log, one curve per decoupled shading mode, with each grid's distinct keys (the
least any cache can shade) and per-pixel and per-sample shading as horizontal lines.

Reads the CSV `shutter bench --csv` wrote in scripts/decoupled-sweeps.sh and the distinct keys of
`default` from keys.md beside it; writes an SVG (no dependencies beyond Python 3).

    python3 scripts/plot-cache-sweep.py docs/quality/decoupled/cache-default.csv \
        docs/quality/decoupled/keys.md docs/quality/decoupled/cache-default.svg
"""
import csv
import math
import sys


def load(csv_path):
    """{mode: [(entries, shading invocations)]} and {rate: invocations} of the rates without a cache."""
    curves, flat = {}, {}
    with open(csv_path, newline="") as f:
        for row in csv.DictReader(f):
            label = row["label"]
            shaded = int(row["shading_invocations"])
            parts = dict(p.split("=", 1) for p in label.split(":")[1:] if "=" in p)
            shading = parts.get("shading", "per-pixel")
            if "cache" in parts:
                curves.setdefault(shading, []).append((int(parts["cache"]), shaded))
            else:
                flat[shading] = shaded
    for points in curves.values():
        points.sort()
    return curves, flat


def keys_of_default(md_path):
    """(pixel grid, AAS) distinct keys of `default` from keys.md."""
    with open(md_path) as f:
        for line in f:
            if line.startswith("| `default`"):
                cells = [c.strip() for c in line.strip().strip("|").split("|")]
                return int(cells[1]), int(cells[3])
    raise SystemExit(f"no `default` row in {md_path}")


def main(csv_path, md_path, out):
    curves, flat = load(csv_path)
    pixel_keys, aas_keys = keys_of_default(md_path)
    W, H, L, R, T, B = 960, 600, 90, 230, 50, 70
    xs = [x for pts in curves.values() for x, _ in pts]
    ys = [y for pts in curves.values() for _, y in pts] + list(flat.values()) + [pixel_keys, aas_keys]
    x0, x1 = math.log2(min(xs)), math.log2(max(xs))
    y0, y1 = math.log10(min(ys) * 0.8), math.log10(max(ys) * 1.25)

    def px(x):
        return L + (math.log2(x) - x0) / (x1 - x0) * (W - L - R)

    def py(y):
        return H - B - (math.log10(y) - y0) / (y1 - y0) * (H - T - B)

    svg = [
        f'<svg xmlns="http://www.w3.org/2000/svg" width="{W}" height="{H}" font-family="sans-serif" font-size="13">',
        f'<rect width="{W}" height="{H}" fill="white"/>',
        f'<text x="{W / 2}" y="24" text-anchor="middle" font-size="16">default, 160×90, S = 16: shading '
        "invocations against cache entries</text>",
    ]
    # Axes and grid.
    e = int(x0)
    while e <= x1:
        x = px(2 ** e)
        svg.append(f'<line x1="{x}" y1="{T}" x2="{x}" y2="{H - B}" stroke="#ddd"/>')
        svg.append(f'<text x="{x}" y="{H - B + 18}" text-anchor="middle">{2 ** e}</text>')
        e += 2
    for d in range(int(math.floor(y0)), int(math.ceil(y1)) + 1):
        for m in (1, 2, 5):
            v = m * 10**d
            if y0 <= math.log10(v) <= y1:
                y = py(v)
                svg.append(f'<line x1="{L}" y1="{y}" x2="{W - R}" y2="{y}" stroke="#ddd"/>')
                svg.append(f'<text x="{L - 6}" y="{y + 4}" text-anchor="end">{v:,}</text>')
    svg.append(f'<rect x="{L}" y="{T}" width="{W - L - R}" height="{H - T - B}" fill="none" stroke="black"/>')
    svg.append(f'<text x="{(L + W - R) / 2}" y="{H - 20}" text-anchor="middle">cache or hash-table entries</text>')
    svg.append(
        f'<text x="20" y="{(T + H - B) / 2}" text-anchor="middle" transform="rotate(-90 20 {(T + H - B) / 2})">'
        "shading invocations</text>"
    )
    colours = {
        "decoupled": "#1f77b4",
        "aas": "#d62728",
        "decoupled-deferred": "#2ca02c",
        "aas-deferred": "#ff7f0e",
        "aas-isotropic": "#9467bd",
        "aas-isotropic-deferred": "#8c564b",
    }
    legend = []
    for name, pts in sorted(curves.items()):
        c = colours.get(name, "black")
        path = " ".join(f"{'M' if i == 0 else 'L'}{px(x):.1f},{py(y):.1f}" for i, (x, y) in enumerate(pts))
        dash = ' stroke-dasharray="6 3"' if name.endswith("deferred") else ""
        svg.append(f'<path d="{path}" fill="none" stroke="{c}" stroke-width="2"{dash}/>')
        for x, y in pts:
            svg.append(f'<circle cx="{px(x):.1f}" cy="{py(y):.1f}" r="3.5" fill="{c}"/>')
        legend.append((name + (" (hash table)" if name.endswith("deferred") else " (memoization)"), c, dash))
    for label, value, c in [
        (f"pixel-grid keys ({pixel_keys:,})", pixel_keys, "#1f77b4"),
        (f"AAS keys ({aas_keys:,})", aas_keys, "#d62728"),
    ] + [(f"{k} ({v:,})", v, "#777") for k, v in sorted(flat.items())]:
        y = py(value)
        svg.append(f'<line x1="{L}" y1="{y}" x2="{W - R}" y2="{y}" stroke="{c}" stroke-dasharray="2 3"/>')
        svg.append(f'<text x="{W - R + 6}" y="{y + 4}" fill="{c}" font-size="11">{label}</text>')
    # The legend in the lower left, below the curves' small-cache end.
    for i, (name, c, dash) in enumerate(legend):
        y = H - B - 14 - 18 * (len(legend) - 1 - i)
        svg.append(f'<line x1="{L + 12}" y1="{y}" x2="{L + 40}" y2="{y}" stroke="{c}" stroke-width="2"{dash}/>')
        svg.append(f'<text x="{L + 46}" y="{y + 4}">{name}</text>')
    svg.append("</svg>")
    with open(out, "w") as f:
        f.write("\n".join(svg) + "\n")
    print(f"wrote {out}")


if __name__ == "__main__":
    if len(sys.argv) != 4:
        raise SystemExit(__doc__)
    main(*sys.argv[1:])
