//! A 3-D path drawn in an isometric projection, coloured by a value along it, with a
//! colour bar (the digital twin's error-along-the-path picture).

use std::fmt::Write as _;

use super::svg::{escape, fmt_tick, header, nice};

/// Isometric view from `(+1, +1, +1)` towards the origin, z up: screen right
/// `(−1, 1, 0)/√2`, screen up `(−1, −1, 2)/√6` (coordinates in any length unit).
pub fn isometric(p: [f64; 3]) -> (f64, f64) {
    let u = (p[1] - p[0]) / std::f64::consts::SQRT_2;
    let v = (2.0 * p[2] - p[0] - p[1]) / 6f64.sqrt();
    (u, v)
}

/// A colour of a perceptually ordered map (viridis stops, linear in between) for
/// `f ∈ [0, 1]` (clamped), as `#rrggbb`.
pub fn colour(f: f64) -> String {
    const STOPS: [[f64; 3]; 5] = [
        [68.0, 1.0, 84.0],
        [59.0, 82.0, 139.0],
        [33.0, 145.0, 140.0],
        [94.0, 201.0, 98.0],
        [253.0, 231.0, 37.0],
    ];
    let f = if f.is_finite() {
        f.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let x = f * (STOPS.len() - 1) as f64;
    let i = (x.floor() as usize).min(STOPS.len() - 2);
    let w = x - i as f64;
    let c: Vec<u8> = (0..3)
        .map(|k| (STOPS[i][k] * (1.0 - w) + STOPS[i + 1][k] * w).round() as u8)
        .collect();
    format!("#{:02x}{:02x}{:02x}", c[0], c[1], c[2])
}

/// The path `points` (3-D, e.g. mm) in isometric projection, each segment coloured by
/// the larger `values` of its two ends (0 … the largest value, rounded up to 1-2-5),
/// over an optional grey `background` path (e.g. the command path). The colour bar is
/// labelled `label` with ticks of `value·unit_scale` (e.g. mm → µm with 1000).
pub fn coloured_path(
    title: &str,
    background: &[[f64; 3]],
    points: &[[f64; 3]],
    values: &[f64],
    label: &str,
    unit_scale: f64,
) -> String {
    let (w, h) = (640.0, 520.0);
    let (l, t, pw, ph) = (20.0, 40.0, 500.0, 460.0);
    let proj: Vec<(f64, f64)> = points.iter().map(|&p| isometric(p)).collect();
    let back: Vec<(f64, f64)> = background.iter().map(|&p| isometric(p)).collect();
    let (mut u0, mut u1, mut v0, mut v1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for &(u, v) in proj.iter().chain(&back) {
        if u.is_finite() && v.is_finite() {
            (u0, u1, v0, v1) = (u0.min(u), u1.max(u), v0.min(v), v1.max(v));
        }
    }
    if u0 > u1 {
        (u0, u1, v0, v1) = (0.0, 1.0, 0.0, 1.0);
    }
    let span = (u1 - u0).max(v1 - v0).max(1e-12);
    let k = (pw / span).min(ph / span);
    let (cu, cv) = (0.5 * (u0 + u1), 0.5 * (v0 + v1));
    let px = |(u, v): (f64, f64)| (l + pw / 2.0 + (u - cu) * k, t + ph / 2.0 - (v - cv) * k);
    let vmax = values
        .iter()
        .copied()
        .filter(|v| v.is_finite())
        .fold(0.0_f64, f64::max);
    let top = nice(vmax * unit_scale) / unit_scale;
    let mut s = String::new();
    header(&mut s, w, h, title);
    if back.len() > 1 {
        let d: Vec<String> = back
            .iter()
            .map(|&p| {
                let (x, y) = px(p);
                format!("{x:.2},{y:.2}")
            })
            .collect();
        let _ = writeln!(
            s,
            r##"<polyline points="{}" fill="none" stroke="#bbb" stroke-width="3"/>"##,
            d.join(" ")
        );
    }
    for i in 1..proj.len() {
        let (x1, y1) = px(proj[i - 1]);
        let (x2, y2) = px(proj[i]);
        let v = values[i - 1].max(values[i]);
        let _ = writeln!(
            s,
            r#"<line x1="{x1:.2}" y1="{y1:.2}" x2="{x2:.2}" y2="{y2:.2}" stroke="{}" stroke-width="1.5"/>"#,
            colour(v / top)
        );
    }
    // Axis triad.
    let (ox, oy) = (l + 30.0, t + ph - 10.0);
    for (name, e) in [
        ("x", [1.0, 0.0, 0.0]),
        ("y", [0.0, 1.0, 0.0]),
        ("z", [0.0, 0.0, 1.0]),
    ] {
        let (u, v) = isometric(e);
        let (x2, y2) = (ox + 25.0 * u, oy - 25.0 * v);
        let _ = writeln!(
            s,
            r##"<line x1="{ox}" y1="{oy}" x2="{x2:.2}" y2="{y2:.2}" stroke="#333"/><text x="{:.2}" y="{:.2}" fill="#333">{name}</text>"##,
            x2 + 3.0 * u.signum(),
            y2 - 3.0 * v.signum() + 4.0
        );
    }
    // Colour bar.
    let (bx, by, bw, bh) = (w - 90.0, t + 20.0, 18.0, ph - 60.0);
    let steps = 64;
    for i in 0..steps {
        let f0 = i as f64 / steps as f64;
        let _ = writeln!(
            s,
            r#"<rect x="{bx}" y="{:.2}" width="{bw}" height="{:.2}" fill="{}"/>"#,
            by + bh * (1.0 - f0 - 1.0 / steps as f64),
            bh / steps as f64 + 0.5,
            colour(f0 + 0.5 / steps as f64)
        );
    }
    let _ = writeln!(
        s,
        r#"<rect x="{bx}" y="{by}" width="{bw}" height="{bh}" fill="none" stroke="black"/>"#
    );
    for i in 0..=4 {
        let f = i as f64 / 4.0;
        let _ = writeln!(
            s,
            r#"<text x="{:.2}" y="{:.2}">{}</text>"#,
            bx + bw + 4.0,
            by + bh * (1.0 - f) + 4.0,
            fmt_tick(top * f * unit_scale)
        );
    }
    let _ = writeln!(
        s,
        r#"<text x="{:.2}" y="{:.2}" text-anchor="middle">{}</text>"#,
        bx + bw / 2.0,
        by - 8.0,
        escape(label)
    );
    s.push_str("</svg>\n");
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn isometric_axes_are_120_degrees_apart_and_equally_short() {
        let e: Vec<(f64, f64)> = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
            .iter()
            .map(|&p| isometric(p))
            .collect();
        for a in &e {
            assert!(((a.0 * a.0 + a.1 * a.1) - 2.0 / 3.0).abs() < 1e-12);
        }
        for i in 0..3 {
            let (a, b) = (e[i], e[(i + 1) % 3]);
            let cos = (a.0 * b.0 + a.1 * b.1) / (2.0 / 3.0);
            assert!((cos + 0.5).abs() < 1e-12, "{cos}");
        }
        // The view direction (1, 1, 1) projects to a point.
        let (u, v) = isometric([1.0, 1.0, 1.0]);
        assert!(u.abs() < 1e-15 && v.abs() < 1e-15);
    }

    #[test]
    fn colours_run_from_the_first_to_the_last_stop() {
        assert_eq!(colour(0.0), "#440154");
        assert_eq!(colour(1.0), "#fde725");
        assert_eq!(colour(2.0), "#fde725");
        assert_eq!(colour(0.5), "#21918c");
        let svg = coloured_path(
            "t",
            &[],
            &[[0.0; 3], [1.0, 0.0, 0.0]],
            &[0.0, 0.002],
            "µm",
            1e3,
        );
        // The one segment takes the larger end value: the top of the bar (2 µm).
        assert!(
            svg.contains(r##"stroke="#fde725""##) && svg.contains(">2</text>"),
            "{svg}"
        );
    }
}
