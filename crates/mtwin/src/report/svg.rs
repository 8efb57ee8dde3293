//! Minimal hand-written SVG plots (no dependencies): a polar plot of a
//! deviation against an angle (the ballbar's picture) and an x–y line plot.
//! Both take named series, draw axes, labels and a legend.

use std::fmt::Write as _;

/// One named series of points; `(x, y)` or `(angle_deg, value)`. Its
/// drawn markers or line carry `class="<name as a slug>"` (lower case,
/// runs of other characters than letters and digits as one `-`), so tests
/// and style sheets can find them.
#[derive(Debug, Clone, PartialEq)]
pub struct Series {
    /// Legend name.
    pub name: String,
    /// `(x, y)` points in the units of the chart's axes.
    pub points: Vec<(f64, f64)>,
    /// CSS colour.
    pub color: String,
    /// Draw markers only (measured data) instead of a line.
    pub markers: bool,
}

const SIZE: f64 = 480.0;

pub(crate) fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

pub(crate) fn header(s: &mut String, w: f64, h: f64, title: &str) {
    let _ = writeln!(
        s,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" viewBox="0 0 {w} {h}" font-family="sans-serif" font-size="12">"#
    );
    let _ = writeln!(s, r#"<rect width="{w}" height="{h}" fill="white"/>"#);
    let _ = writeln!(
        s,
        r#"<text x="{}" y="20" text-anchor="middle" font-size="14">{}</text>"#,
        w / 2.0,
        escape(title)
    );
}

fn legend(s: &mut String, series: &[Series], x: f64, y: f64) {
    for (k, se) in series.iter().enumerate() {
        let yy = y + 16.0 * k as f64;
        if se.markers {
            let _ = writeln!(
                s,
                r#"<circle cx="{}" cy="{}" r="2.5" fill="{}"/>"#,
                x + 10.0,
                yy - 4.0,
                se.color
            );
        } else {
            let _ = writeln!(
                s,
                r#"<line x1="{x}" y1="{}" x2="{}" y2="{}" stroke="{}" stroke-width="2"/>"#,
                yy - 4.0,
                x + 20.0,
                yy - 4.0,
                se.color
            );
        }
        let _ = writeln!(
            s,
            r#"<text x="{}" y="{yy}">{}</text>"#,
            x + 26.0,
            escape(&se.name)
        );
    }
}

/// `name` as a CSS class: lower case, other runs than letters and digits as one `-`.
fn slug(name: &str) -> String {
    let mut out = String::new();
    for c in name.chars() {
        if c.is_alphanumeric() {
            out.extend(c.to_lowercase());
        } else if !out.is_empty() && !out.ends_with('-') {
            out.push('-');
        }
    }
    out.trim_end_matches('-').to_string()
}

fn path(s: &mut String, pts: &[(f64, f64)], se: &Series) {
    let class = escape(&slug(&se.name));
    if se.markers {
        for (x, y) in pts {
            let _ = writeln!(
                s,
                r#"<circle class="{class}" cx="{x:.2}" cy="{y:.2}" r="2.5" fill="{}"/>"#,
                se.color
            );
        }
    } else if !pts.is_empty() {
        let d: Vec<String> = pts.iter().map(|(x, y)| format!("{x:.2},{y:.2}")).collect();
        let _ = writeln!(
            s,
            r#"<polyline class="{class}" points="{}" fill="none" stroke="{}" stroke-width="1.5"/>"#,
            d.join(" "),
            se.color
        );
    }
}

/// A polar plot: each point `(angle_deg, value)` is drawn at the angle (0°
/// to the right, counter-clockwise) and at radius `R·(0.5 + 0.45·value/v)`,
/// `v` the largest `|value|` rounded up, so the middle ring is value 0 and
/// the inner and outer rings are `−v` and `+v`, labelled in `unit`
/// after multiplying by `unit_scale` (e.g. 1000 for mm → µm).
pub fn polar(title: &str, series: &[Series], unit: &str, unit_scale: f64) -> String {
    let vmax = series
        .iter()
        .flat_map(|s| s.points.iter().map(|p| p.1.abs()))
        .filter(|v| v.is_finite())
        .fold(0.0_f64, f64::max);
    let v = nice(vmax * unit_scale) / unit_scale;
    let (cx, cy, r) = (SIZE / 2.0, SIZE / 2.0 + 10.0, SIZE / 2.0 - 50.0);
    let rad = |val: f64| r * (0.5 + 0.45 * val / v);
    let mut s = String::new();
    header(
        &mut s,
        SIZE,
        SIZE + 20.0 + 16.0 * series.len() as f64,
        title,
    );
    for (k, val) in [-v, 0.0, v].into_iter().enumerate() {
        let _ = writeln!(
            s,
            r##"<circle cx="{cx}" cy="{cy}" r="{:.2}" fill="none" stroke="{}" stroke-dasharray="{}"/>"##,
            rad(val),
            if k == 1 { "#888" } else { "#ccc" },
            if k == 1 { "none" } else { "4 3" }
        );
        let _ = writeln!(
            s,
            r##"<text x="{:.2}" y="{:.2}" fill="#555">{} {unit}</text>"##,
            cx + 3.0,
            cy - rad(val) - 2.0,
            fmt_tick(val * unit_scale)
        );
    }
    for deg in (0..360).step_by(30) {
        let a = (deg as f64).to_radians();
        let (x2, y2) = (cx + (r + 8.0) * a.cos(), cy - (r + 8.0) * a.sin());
        let _ = writeln!(
            s,
            r##"<line x1="{cx}" y1="{cy}" x2="{x2:.2}" y2="{y2:.2}" stroke="#eee"/>"##
        );
        let _ = writeln!(
            s,
            r#"<text x="{:.2}" y="{:.2}" text-anchor="middle">{deg}°</text>"#,
            cx + (r + 22.0) * a.cos(),
            cy - (r + 22.0) * a.sin() + 4.0
        );
    }
    for se in series {
        let pts: Vec<(f64, f64)> = se
            .points
            .iter()
            .filter(|p| p.0.is_finite() && p.1.is_finite())
            .map(|&(deg, val)| {
                let a = deg.to_radians();
                (cx + rad(val) * a.cos(), cy - rad(val) * a.sin())
            })
            .collect();
        path(&mut s, &pts, se);
    }
    legend(&mut s, series, 20.0, SIZE + 20.0);
    s.push_str("</svg>\n");
    s
}

/// Horizontal grid lines with their labels at the ticks of `yt` within
/// `y0..y1`, across a plot of left edge `l` and width `w` (`py`: value to
/// SVG y).
fn y_grid(
    s: &mut String,
    yt: &Ticks,
    (y0, y1): (f64, f64),
    (l, w): (f64, f64),
    py: impl Fn(f64) -> f64,
) {
    for fy in yt.within(y0, y1) {
        let _ = writeln!(
            s,
            r##"<line x1="{l}" y1="{0:.2}" x2="{1}" y2="{0:.2}" stroke="#eee"/><text x="{2}" y="{3:.2}" text-anchor="end">{4}</text>"##,
            py(fy),
            l + w,
            l - 4.0,
            py(fy) + 4.0,
            yt.label(fy)
        );
    }
}

/// The y axis label, turned upright along the left edge of a plot of top
/// `t` and height `h`.
fn y_axis_label(s: &mut String, (t, h): (f64, f64), y_label: &str) {
    let _ = writeln!(
        s,
        r#"<text x="16" y="{}" text-anchor="middle" transform="rotate(-90 16 {})">{}</text>"#,
        t + h / 2.0,
        t + h / 2.0,
        escape(y_label)
    );
}

/// An x–y line plot with axis labels.
pub fn xy(title: &str, x_label: &str, y_label: &str, series: &[Series]) -> String {
    let pts = || {
        series
            .iter()
            .flat_map(|s| s.points.iter())
            .filter(|p| p.0.is_finite() && p.1.is_finite())
    };
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for &(x, y) in pts() {
        (x0, x1, y0, y1) = (x0.min(x), x1.max(x), y0.min(y), y1.max(y));
    }
    if x0 > x1 {
        (x0, x1, y0, y1) = (0.0, 1.0, 0.0, 1.0);
    }
    if x1 == x0 {
        x1 = x0 + 1.0;
    }
    if y1 == y0 {
        y1 = y0 + 1.0;
    }
    // x keeps the data range (a travel is what it is), y widens to whole steps.
    let xt = Ticks::over(x0, x1);
    let yt = Ticks::over(y0, y1);
    (y0, y1) = (yt.lo, yt.hi);
    let (l, t, w, h) = (70.0, 40.0, SIZE - 100.0, SIZE - 120.0);
    let px = |x: f64| l + (x - x0) / (x1 - x0) * w;
    let py = |y: f64| t + h - (y - y0) / (y1 - y0) * h;
    let mut s = String::new();
    header(&mut s, SIZE, SIZE + 16.0 * series.len() as f64, title);
    let _ = writeln!(
        s,
        r#"<rect x="{l}" y="{t}" width="{w}" height="{h}" fill="none" stroke="black"/>"#
    );
    for fx in xt.within(x0, x1) {
        let _ = writeln!(
            s,
            r#"<text x="{:.2}" y="{}" text-anchor="middle">{}</text>"#,
            px(fx),
            t + h + 16.0,
            xt.label(fx)
        );
    }
    y_grid(&mut s, &yt, (y0, y1), (l, w), py);
    let _ = writeln!(
        s,
        r#"<text x="{}" y="{}" text-anchor="middle">{}</text>"#,
        l + w / 2.0,
        t + h + 34.0,
        escape(x_label)
    );
    y_axis_label(&mut s, (t, h), y_label);
    for se in series {
        let p: Vec<(f64, f64)> = se
            .points
            .iter()
            .filter(|p| p.0.is_finite() && p.1.is_finite())
            .map(|&(x, y)| (px(x), py(y)))
            .collect();
        path(&mut s, &p, se);
    }
    legend(&mut s, series, 20.0, SIZE);
    s.push_str("</svg>\n");
    s
}

/// A grouped bar chart: one group per entry of `groups`, one bar per series in
/// each group; each series is `(name, colour, values)` with one value per group
/// (non-finite values are left out). Values start from 0.
pub fn bars(
    title: &str,
    y_label: &str,
    groups: &[String],
    series: &[(String, String, Vec<f64>)],
) -> String {
    let vals = || {
        series
            .iter()
            .flat_map(|s| s.2.iter())
            .filter(|v| v.is_finite())
    };
    let hi = vals().fold(0.0_f64, |a, &b| a.max(b));
    let lo = vals().fold(0.0_f64, |a, &b| a.min(b));
    let (y0, y1) = if hi > lo { (lo, hi) } else { (0.0, 1.0) };
    let yt = Ticks::over(y0, y1);
    let (y0, y1) = (yt.lo, yt.hi);
    let (l, t, w, h) = (70.0, 40.0, SIZE - 100.0, SIZE - 140.0);
    let py = |y: f64| t + h - (y - y0) / (y1 - y0) * h;
    let mut s = String::new();
    header(
        &mut s,
        SIZE,
        SIZE - 20.0 + 16.0 * series.len() as f64,
        title,
    );
    let _ = writeln!(
        s,
        r#"<rect x="{l}" y="{t}" width="{w}" height="{h}" fill="none" stroke="black"/>"#
    );
    y_grid(&mut s, &yt, (y0, y1), (l, w), py);
    y_axis_label(&mut s, (t, h), y_label);
    let gw = w / groups.len().max(1) as f64;
    let bw = gw * 0.8 / series.len().max(1) as f64;
    for (g, name) in groups.iter().enumerate() {
        let gx = l + gw * g as f64 + gw * 0.1;
        let _ = writeln!(
            s,
            r#"<text x="{:.2}" y="{}" text-anchor="middle">{}</text>"#,
            l + gw * (g as f64 + 0.5),
            t + h + 16.0,
            escape(name)
        );
        for (k, (_, color, v)) in series.iter().enumerate() {
            let Some(&v) = v.get(g).filter(|v| v.is_finite()) else {
                continue;
            };
            let (ya, yb) = (py(v.max(0.0)), py(v.min(0.0)));
            let _ = writeln!(
                s,
                r#"<rect class="bar" x="{:.2}" y="{ya:.2}" width="{:.2}" height="{:.2}" fill="{color}"/>"#,
                gx + bw * k as f64,
                bw * 0.92,
                (yb - ya).max(0.5)
            );
        }
    }
    let legend_series: Vec<Series> = series
        .iter()
        .map(|(n, c, _)| Series {
            name: n.clone(),
            points: Vec::new(),
            color: c.clone(),
            markers: false,
        })
        .collect();
    legend(&mut s, &legend_series, 20.0, t + h + 44.0);
    s.push_str("</svg>\n");
    s
}

/// The smallest of 1, 2, 5 × 10^k not below `x` (1 for `x ≤ 0`).
pub(crate) fn nice(x: f64) -> f64 {
    if x.is_nan() || x <= 0.0 || !x.is_finite() {
        return 1.0;
    }
    let e = 10f64.powf(x.log10().floor());
    [1.0, 2.0, 5.0, 10.0]
        .into_iter()
        .map(|m| m * e)
        .find(|&v| v >= x * (1.0 - 1e-12))
        .unwrap_or(10.0 * e)
}

/// Axis ticks at whole multiples of a step of 1, 2, 2.5 or 5 × 10^k, about
/// four intervals over the data.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Ticks {
    /// First tick at or below the data, a multiple of `step`.
    pub lo: f64,
    /// Last tick at or above the data, a multiple of `step`.
    pub hi: f64,
    pub step: f64,
    /// Decimals that show every multiple of `step` exactly.
    decimals: usize,
}

impl Ticks {
    /// Ticks covering `[a, b]` (`a < b`, both finite; anything else gives 0…1).
    pub(crate) fn over(a: f64, b: f64) -> Ticks {
        let (a, b) = if a.is_finite() && b.is_finite() && b > a {
            (a, b)
        } else {
            (0.0, 1.0)
        };
        let raw = (b - a) / 4.0;
        let e = 10f64.powf(raw.log10().floor());
        let m = [1.0, 2.0, 2.5, 5.0, 10.0]
            .into_iter()
            .find(|&m| m * e >= raw * (1.0 - 1e-12))
            .unwrap_or(10.0);
        let step = m * e;
        let decimals = (0..12)
            .find(|&d| {
                let v = step * 10f64.powi(d as i32);
                (v - v.round()).abs() < 1e-6 * v.max(1.0)
            })
            .unwrap_or(12);
        Ticks {
            lo: (a / step + 1e-9).floor() * step,
            hi: (b / step - 1e-9).ceil() * step,
            step,
            decimals,
        }
    }

    /// The multiples of `step` within `[a, b]` (to a millionth of a step).
    pub(crate) fn within(&self, a: f64, b: f64) -> impl Iterator<Item = f64> + use<> {
        let step = self.step;
        let first = (a / step - 1e-6).ceil() as i64;
        let last = (b / step + 1e-6).floor() as i64;
        (first..=last).map(move |k| k as f64 * step)
    }

    /// `v` printed with the step's decimals (no "-0").
    pub(crate) fn label(&self, v: f64) -> String {
        let s = format!("{:.*}", self.decimals, v);
        if s.trim_start_matches('-')
            .chars()
            .all(|c| c == '0' || c == '.')
        {
            "0".into()
        } else {
            s
        }
    }
}

pub(crate) fn fmt_tick(v: f64) -> String {
    let s = format!("{v:.3}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" { "0".into() } else { s.into() }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_are_whole_steps_covering_the_data() {
        // −1083.1 … 437.0: a quarter of the span is 380 → step 500.
        let t = Ticks::over(-1083.097, 437.024);
        assert_eq!((t.lo, t.hi, t.step), (-1500.0, 500.0, 500.0));
        let v: Vec<String> = t.within(t.lo, t.hi).map(|v| t.label(v)).collect();
        assert_eq!(v, ["-1500", "-1000", "-500", "0", "500"]);
        // −45 … 45 deg: step 25 (2.5 × 10), ticks inside the travel only.
        let t = Ticks::over(-45.0, 45.0);
        assert_eq!(t.step, 25.0);
        let v: Vec<f64> = t.within(-45.0, 45.0).collect();
        assert_eq!(v, [-25.0, 0.0, 25.0]);
        let t = Ticks::over(-1000.0, 0.0);
        assert_eq!((t.step, t.label(-750.0)), (250.0, "-750".into()));
        // Small steps keep their decimals; a 2.5 mantissa needs one more.
        let t = Ticks::over(0.0, 1.0);
        assert_eq!(
            (t.step, t.label(0.25), t.label(-1e-17)),
            (0.25, "0.25".into(), "0".into())
        );
        let t = Ticks::over(0.0, 0.0004);
        assert_eq!((t.step, t.label(0.0003)), (0.0001, "0.0003".into()));
        // Degenerate input still gives a usable axis.
        assert_eq!(Ticks::over(f64::NAN, 1.0).step, 0.25);
    }

    #[test]
    fn nice_rounds_up_to_1_2_5() {
        assert_eq!(nice(3.2), 5.0);
        assert_eq!(nice(0.15), 0.2);
    }

    #[test]
    fn bars_are_proportional_to_their_values() {
        let svg = bars(
            "t",
            "µm",
            &["a".into(), "b".into()],
            &[("s".into(), "red".into(), vec![1.0, 4.0])],
        );
        // Axis runs 0…5 (nice(4)); bar heights are value/5 of the plot height.
        let heights: Vec<f64> = svg
            .lines()
            .filter(|l| l.contains("class=\"bar\""))
            .map(|l| {
                let i = l.find("height=\"").unwrap() + 8;
                l[i..].split('"').next().unwrap().parse().unwrap()
            })
            .collect();
        assert_eq!(heights.len(), 2);
        assert!((heights[1] / heights[0] - 4.0).abs() < 1e-2, "{heights:?}");
        assert_eq!(nice(10.0), 10.0);
        assert_eq!(nice(0.0), 1.0);
    }

    #[test]
    fn polar_places_zero_on_the_middle_ring() {
        let se = Series {
            name: "a<b".into(),
            points: vec![(0.0, 0.0), (90.0, 0.002)],
            color: "red".into(),
            markers: true,
        };
        let svg = polar("t", &[se], "µm", 1000.0);
        // v = 2 µm: value 0 at r = 0.5 R = 95 px right of the centre (240 + 95 = 335).
        assert!(svg.contains(r#"cx="335.00" cy="250.00""#), "{svg}");
        // value +v at 90°: r = 0.95 R = 180.5 px above the centre.
        assert!(svg.contains(r#"cx="240.00" cy="69.50""#), "{svg}");
        assert!(svg.contains("a&lt;b") && svg.ends_with("</svg>\n"));
        assert_eq!(svg.matches(r#"class="a-b""#).count(), 2);
        assert_eq!(slug("Model (run 2)"), "model-run-2");
    }

    #[test]
    fn xy_maps_the_data_range_to_the_frame() {
        let se = Series {
            name: "l".into(),
            points: vec![(0.0, 0.0), (1.0, 2.0)],
            color: "blue".into(),
            markers: false,
        };
        let svg = xy("t", "x", "y", &[se]);
        assert!(svg.contains("70.00,400.00 450.00,40.00"), "{svg}");
    }
}
