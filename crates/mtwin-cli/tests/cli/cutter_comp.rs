//! Cutter radius compensation against closed-form geometry (independent of
//! LinuxCNC): around a convex polygon with the tool outside, every point of
//! the compensated path is exactly one tool radius from the polygon, and
//! the path is the polygon's perimeter plus one full turn of the radius
//! (the corner arcs turn once around in total).

use std::f64::consts::TAU;

use mtwin::gcode::{self, EventKind, InterpOptions};
use proptest::prelude::*;

/// Distance from `p` to the segment `a`–`b`.
fn to_segment(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    let t = (((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / (dx * dx + dy * dy)).clamp(0.0, 1.0);
    (p[0] - a[0] - t * dx).hypot(p[1] - a[1] - t * dy)
}

/// Distance from `p` (outside) to the boundary of the polygon.
fn to_polygon(p: [f64; 2], poly: &[[f64; 2]]) -> f64 {
    (0..poly.len())
        .map(|i| to_segment(p, poly[i], poly[(i + 1) % poly.len()]))
        .fold(f64::INFINITY, f64::min)
}

/// Runs `program`, returning the moves of the lines `lines` (inclusive)
/// as sampled points and their total length, and the whole path's
/// continuity error.
fn compensated_path(program: &str, lines: (u64, u64)) -> (Vec<[f64; 2]>, f64, f64) {
    let mut points = Vec::new();
    let mut length = 0.0;
    let mut last: Option<[f64; 2]> = None;
    let mut jump: f64 = 0.0;
    gcode::interpret(program.as_bytes(), InterpOptions::default(), |_, events| {
        for e in events {
            let (from, to) = match &e.kind {
                EventKind::Feed(m) | EventKind::Traverse(m) => {
                    ([m.from.0[0], m.from.0[1]], [m.to.0[0], m.to.0[1]])
                }
                EventKind::Arc(a) => ([a.from.0[0], a.from.0[1]], [a.to.0[0], a.to.0[1]]),
                _ => continue,
            };
            if let Some(l) = last {
                jump = jump.max((l[0] - from[0]).hypot(l[1] - from[1]));
            }
            last = Some(to);
            if e.at.line < lines.0 || e.at.line > lines.1 {
                continue;
            }
            match &e.kind {
                EventKind::Feed(_) => {
                    length += (to[0] - from[0]).hypot(to[1] - from[1]);
                    for k in 0..=20 {
                        let t = f64::from(k) / 20.0;
                        points.push([
                            from[0] + t * (to[0] - from[0]),
                            from[1] + t * (to[1] - from[1]),
                        ]);
                    }
                }
                EventKind::Arc(a) => {
                    length += a.xyz_length();
                    let c = [a.center[0], a.center[1]];
                    let r = (from[0] - c[0]).hypot(from[1] - c[1]);
                    let r_end = (to[0] - c[0]).hypot(to[1] - c[1]);
                    assert!((r - r_end).abs() < 1e-9, "arc radii {r} {r_end}");
                    let a0 = (from[1] - c[1]).atan2(from[0] - c[0]);
                    for k in 0..=20 {
                        let ang = a0 + a.sweep() * f64::from(k) / 20.0;
                        points.push([c[0] + r * ang.cos(), c[1] + r * ang.sin()]);
                    }
                }
                _ => panic!("a traverse among the feeds"),
            }
        }
        Ok(())
    })
    .unwrap();
    (points, length, jump)
}

/// A convex polygon: `n` points on a circle of radius `big` about
/// (`cx`, `cy`) at angles with gaps from `weights` (each gap at least 0.25
/// rad so every corner turns by more than LinuxCNC's 0.05 rad, and an
/// arc goes around it), counter-clockwise.
fn polygon(cx: f64, cy: f64, big: f64, phase: f64, weights: &[f64]) -> Vec<[f64; 2]> {
    let n = weights.len() as f64;
    let free = TAU - 0.25 * n;
    let total: f64 = weights.iter().sum();
    let mut angle = phase;
    let mut out = Vec::new();
    for w in weights {
        out.push([cx + big * angle.cos(), cy + big * angle.sin()]);
        angle += 0.25 + free * w / total;
    }
    out
}

fn num(v: f64) -> String {
    format!("{v:.9}")
}

/// The program: tool outside a counter-clockwise polygon (G42.1 D, or G41.1
/// with the polygon run clockwise), entry from outside to the first
/// corner, once around and along the first side again, G40, exit.
fn program(poly: &[[f64; 2]], diameter: f64, left: bool) -> (String, (u64, u64)) {
    let mut order: Vec<[f64; 2]> = poly.to_vec();
    if left {
        order.reverse();
    }
    let c = poly
        .iter()
        .fold([0.0, 0.0], |s, p| [s[0] + p[0], s[1] + p[1]]);
    let c = [c[0] / poly.len() as f64, c[1] / poly.len() as f64];
    let v0 = order[0];
    // Outwards from the centroid through the first corner, at least a
    // diameter away: LinuxCNC refuses an entry move not longer than the
    // radius (a polygon with two corners close together has its centroid
    // near the third).
    let (dx, dy) = (v0[0] - c[0], v0[1] - c[1]);
    let k = dx.hypot(dy).max(diameter) / dx.hypot(dy);
    let start = [v0[0] + k * dx, v0[1] + k * dy];
    let mut lines = vec![
        "G21 G17 G90 G94 F500".to_string(),
        format!("G0 X{} Y{}", num(start[0]), num(start[1])),
        format!("G4{}.1 D{}", if left { 1 } else { 2 }, num(diameter)),
        format!("G1 X{} Y{}", num(v0[0]), num(v0[1])),
    ];
    // Line numbers (1-based) of the sides after the first.
    let first = lines.len() as u64 + 2;
    for p in order.iter().skip(1).chain([&order[0], &order[1]]) {
        lines.push(format!("G1 X{} Y{}", num(p[0]), num(p[1])));
    }
    let last = lines.len() as u64;
    lines.push("G40".into());
    lines.push(format!("G0 X{} Y{}", num(start[0]), num(start[1])));
    lines.push("M2".into());
    (lines.join("\n") + "\n", (first, last))
}

/// The closed-form checks around `poly` with a tool of `diameter`: no jump,
/// every point one radius from the polygon, the length its perimeter plus
/// one turn of the radius.
fn check_outside(poly: &[[f64; 2]], diameter: f64, left: bool) -> Result<(), String> {
    let (text, lines) = program(poly, diameter, left);
    let (points, length, jump) = compensated_path(&text, lines);
    let r = diameter / 2.0;
    if jump >= 1e-9 {
        return Err(format!("the path jumps by {jump}"));
    }
    for p in &points {
        let d = to_polygon(*p, poly);
        if (d - r).abs() >= 1e-7 {
            return Err(format!("point {p:?} at {d}, radius {r}\n{text}"));
        }
    }
    let perimeter: f64 = (0..poly.len())
        .map(|i| {
            let (a, b) = (poly[i], poly[(i + 1) % poly.len()]);
            (b[0] - a[0]).hypot(b[1] - a[1])
        })
        .sum();
    let expected = perimeter + TAU * r;
    if (length - expected).abs() >= 1e-7 {
        return Err(format!("length {length}, expected {expected}\n{text}"));
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn outside_a_convex_polygon_the_tool_stays_one_radius_away(
        cx in -50.0f64..50.0,
        cy in -50.0f64..50.0,
        big in 20.0f64..80.0,
        phase in 0.0f64..TAU,
        weights in proptest::collection::vec(0.05f64..1.0, 3..9),
        diameter in 0.5f64..12.0,
        left in any::<bool>(),
    ) {
        let poly = polygon(cx, cy, big, phase, &weights);
        let checked = check_outside(&poly, diameter, left);
        prop_assert!(checked.is_ok(), "{}", checked.unwrap_err());
    }
}

/// A case the random search found: two corners close together put the
/// centroid near the third, and an entry move from twice the centroid's
/// distance was shorter than the radius (LinuxCNC refuses it).
#[test]
fn a_triangle_with_two_close_corners_gets_an_entry_longer_than_the_radius() {
    let poly = polygon(0.0, 0.0, 20.0, 0.0, &[0.7568518839193514, 0.05, 0.05]);
    check_outside(&poly, 10.252341661869478, true).unwrap();
}

#[test]
fn inside_a_square_the_tool_is_one_radius_in_from_each_side() {
    // A 20 mm square run counter-clockwise with the tool on the left
    // (inside), radius 3: the corners are cut where the offset sides meet,
    // 3 mm in from both sides.
    let text = "G21 G17 G90 G94 F300\nG0 X10 Y10\nG41.1 D6\nG1 X0 Y0\nX20 Y0\nX20 Y20\nX0 Y20\nX0 Y0\nX20 Y0\nG40\nG0 X10 Y10\nM2\n";
    let mut ends = Vec::new();
    gcode::interpret(text.as_bytes(), InterpOptions::default(), |_, events| {
        for e in events {
            if let EventKind::Feed(m) = &e.kind {
                ends.push((e.at.line, [m.to.0[0], m.to.0[1]]));
            }
        }
        Ok(())
    })
    .unwrap();
    let corner = |l: u64| ends.iter().find(|(line, _)| *line == l).unwrap().1;
    let close = |a: [f64; 2], b: [f64; 2]| (a[0] - b[0]).hypot(a[1] - b[1]) < 1e-9;
    assert!(close(corner(5), [17.0, 3.0]), "{:?}", corner(5));
    assert!(close(corner(6), [17.0, 17.0]), "{:?}", corner(6));
    assert!(close(corner(7), [3.0, 17.0]), "{:?}", corner(7));
    assert!(close(corner(8), [3.0, 3.0]), "{:?}", corner(8));
}
