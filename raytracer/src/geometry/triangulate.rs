//! Ear-clipping triangulation of planar polygons (convex or concave, with
//! Radiance-style seams to holes), done in 2D in the polygon's plane.

use super::Vec3;

/// 2D projection of a polygon onto the coordinate plane most parallel to it,
/// oriented so that the polygon is counter-clockwise (positive area) in 2D.
pub(crate) fn project(vertices: &[Vec3], normal: Vec3) -> Vec<[f64; 2]> {
    let k = normal.abs().max_position();
    let (mut u, mut v) = ((k + 1) % 3, (k + 2) % 3);
    if normal[k] < 0.0 {
        std::mem::swap(&mut u, &mut v);
    }
    vertices.iter().map(|p| [p[u], p[v]]).collect()
}

#[inline]
fn orient(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> f64 {
    (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
}

/// True when `p` lies inside or on the boundary of the counter-clockwise triangle `a b c`.
#[inline]
fn in_triangle(p: [f64; 2], a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> bool {
    orient(a, b, p) >= 0.0 && orient(b, c, p) >= 0.0 && orient(c, a, p) >= 0.0
}

/// Triangulates a simple polygon given counter-clockwise in 2D. Returns
/// triangles as index triples into `pts`, each counter-clockwise (so wound
/// like the polygon). Collinear vertices are clipped without emitting a
/// zero-area triangle. Self-intersecting input still yields a triangulation
/// covering the vertices (the most convex corner is clipped when no proper
/// ear exists), never an infinite loop.
pub(crate) fn ear_clip(pts: &[[f64; 2]]) -> Vec<[u32; 3]> {
    let n = pts.len();
    let mut out = Vec::with_capacity(n.saturating_sub(2));
    if n < 3 {
        return out;
    }
    if n == 3 {
        out.push([0, 1, 2]);
        return out;
    }
    // Scale for the "collinear" tolerance.
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for p in pts {
        for a in 0..2 {
            lo[a] = lo[a].min(p[a]);
            hi[a] = hi[a].max(p[a]);
        }
    }
    let size = (hi[0] - lo[0]).max(hi[1] - lo[1]);
    let area_eps = size * size * 1e-14;

    let mut idx: Vec<u32> = (0..n as u32).collect();
    while idx.len() > 3 {
        let m = idx.len();
        let mut clipped = false;
        let mut best: Option<(usize, f64)> = None;
        for i in 0..m {
            let (ip, ic, inx) = (idx[(i + m - 1) % m], idx[i], idx[(i + 1) % m]);
            let (a, b, c) = (pts[ip as usize], pts[ic as usize], pts[inx as usize]);
            let o = orient(a, b, c);
            if o.abs() <= area_eps {
                // Collinear (or a zero-width spike): drop the vertex, no triangle.
                // Only if the neighbours don't fold back over each other in a way
                // that would lose area: a straight continuation or a spike both
                // leave the remaining outline covering the same region.
                idx.remove(i);
                clipped = true;
                break;
            }
            if o < 0.0 {
                continue; // reflex
            }
            if best.is_none_or(|(_, bo)| o > bo) {
                best = Some((i, o));
            }
            let blocked = idx.iter().any(|&j| {
                if j == ip || j == ic || j == inx {
                    return false;
                }
                let p = pts[j as usize];
                // Vertices coinciding with the ear's corners (seams) never block.
                if p == a || p == b || p == c {
                    return false;
                }
                in_triangle(p, a, b, c)
            });
            if !blocked {
                out.push([ip, ic, inx]);
                idx.remove(i);
                clipped = true;
                break;
            }
        }
        if !clipped {
            // No ear: numerically degenerate or self-intersecting input.
            // Clip the most convex corner (or any corner) to guarantee progress.
            let i = best.map_or(0, |(i, _)| i);
            let m = idx.len();
            let (ip, ic, inx) = (idx[(i + m - 1) % m], idx[i], idx[(i + 1) % m]);
            out.push([ip, ic, inx]);
            idx.remove(i);
        }
    }
    let (a, b, c) = (
        pts[idx[0] as usize],
        pts[idx[1] as usize],
        pts[idx[2] as usize],
    );
    if orient(a, b, c).abs() > area_eps {
        out.push([idx[0], idx[1], idx[2]]);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn area(pts: &[[f64; 2]], tris: &[[u32; 3]]) -> f64 {
        tris.iter()
            .map(|t| 0.5 * orient(pts[t[0] as usize], pts[t[1] as usize], pts[t[2] as usize]))
            .sum()
    }

    fn poly_area(pts: &[[f64; 2]]) -> f64 {
        let n = pts.len();
        (0..n)
            .map(|i| 0.5 * (pts[i][0] * pts[(i + 1) % n][1] - pts[(i + 1) % n][0] * pts[i][1]))
            .sum()
    }

    #[test]
    fn concave_l_shape() {
        let pts = [
            [0.0, 0.0],
            [2.0, 0.0],
            [2.0, 1.0],
            [1.0, 1.0],
            [1.0, 2.0],
            [0.0, 2.0],
        ];
        let tris = ear_clip(&pts);
        assert_eq!(tris.len(), 4);
        for t in &tris {
            assert!(orient(pts[t[0] as usize], pts[t[1] as usize], pts[t[2] as usize]) > 0.0);
        }
        assert!((area(&pts, &tris) - 3.0).abs() < 1e-12);
    }

    #[test]
    fn square_with_seamed_hole() {
        // Outer square CCW, seam to a hole traversed CW, back along the seam.
        let pts = [
            [0.0, 0.0],
            [4.0, 0.0],
            [4.0, 4.0],
            [0.0, 4.0],
            [0.0, 0.0],
            [1.0, 1.0],
            [1.0, 3.0],
            [3.0, 3.0],
            [3.0, 1.0],
            [1.0, 1.0],
        ];
        let tris = ear_clip(&pts);
        let expect = poly_area(&pts);
        assert!((expect - 12.0).abs() < 1e-12);
        assert!(
            (area(&pts, &tris) - 12.0).abs() < 1e-9,
            "area {}",
            area(&pts, &tris)
        );
        for t in &tris {
            assert!(orient(pts[t[0] as usize], pts[t[1] as usize], pts[t[2] as usize]) > 0.0);
        }
    }

    #[test]
    fn collinear_vertices_dropped() {
        let pts = [[0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [2.0, 2.0], [0.0, 2.0]];
        let tris = ear_clip(&pts);
        assert!((area(&pts, &tris) - 4.0).abs() < 1e-12);
        assert!(tris.iter().all(|t| orient(
            pts[t[0] as usize],
            pts[t[1] as usize],
            pts[t[2] as usize]
        ) > 0.0));
    }

    #[test]
    fn star_polygon() {
        // 5-pointed star (concave, 10 vertices).
        let pts: Vec<[f64; 2]> = (0..10)
            .map(|i| {
                let r = if i % 2 == 0 { 1.0 } else { 0.4 };
                let a = std::f64::consts::PI * 2.0 * i as f64 / 10.0;
                [r * a.cos(), r * a.sin()]
            })
            .collect();
        let tris = ear_clip(&pts);
        assert_eq!(tris.len(), 8);
        assert!((area(&pts, &tris) - poly_area(&pts)).abs() < 1e-12);
    }
}
