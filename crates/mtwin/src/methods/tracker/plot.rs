//! A small SVG chart of the tool-tip error per point before and after
//! identification (no dependencies).

use std::fmt::Write;

/// An SVG line chart of `before[k]` and `after[k]` (mm, plotted in µm)
/// against the point index, 800×400 px.
pub fn error_chart(title: &str, before: &[f64], after: &[f64]) -> String {
    let (w, h, left, right, top, bottom) = (800.0, 400.0, 60.0, 20.0, 30.0, 40.0);
    let n = before.len().max(after.len()).max(2);
    let ymax = before
        .iter()
        .chain(after)
        .map(|v| v * 1e3)
        .filter(|v| v.is_finite())
        .fold(0.0, f64::max)
        .max(1e-9);
    let px = |k: usize| left + (w - left - right) * k as f64 / (n - 1) as f64;
    let py = |v: f64| top + (h - top - bottom) * (1.0 - v * 1e3 / ymax);
    let line = |vals: &[f64], colour: &str| {
        let pts: Vec<String> = vals
            .iter()
            .enumerate()
            .map(|(k, &v)| format!("{:.2},{:.2}", px(k), py(v)))
            .collect();
        format!(
            "<polyline fill=\"none\" stroke=\"{colour}\" stroke-width=\"1.5\" points=\"{}\"/>\n",
            pts.join(" ")
        )
    };
    let esc = |s: &str| {
        s.replace('&', "&amp;")
            .replace('<', "&lt;")
            .replace('>', "&gt;")
    };
    let mut s = String::new();
    let _ = write!(
        s,
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w}\" height=\"{h}\" viewBox=\"0 0 {w} {h}\">\n\
         <rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n\
         <text x=\"{}\" y=\"20\" font-family=\"sans-serif\" font-size=\"14\">{}</text>\n\
         <line x1=\"{left}\" y1=\"{}\" x2=\"{}\" y2=\"{}\" stroke=\"black\"/>\n\
         <line x1=\"{left}\" y1=\"{top}\" x2=\"{left}\" y2=\"{}\" stroke=\"black\"/>\n\
         <text x=\"5\" y=\"{}\" font-family=\"sans-serif\" font-size=\"11\">{:.1} µm</text>\n\
         <text x=\"5\" y=\"{}\" font-family=\"sans-serif\" font-size=\"11\">0</text>\n\
         <text x=\"{}\" y=\"{}\" font-family=\"sans-serif\" font-size=\"11\">point</text>\n",
        left,
        esc(title),
        h - bottom,
        w - right,
        h - bottom,
        h - bottom,
        top + 4.0,
        ymax,
        h - bottom,
        w / 2.0,
        h - 10.0,
    );
    s.push_str(&line(before, "#c0392b"));
    s.push_str(&line(after, "#2471a3"));
    let _ = write!(
        s,
        "<text x=\"{}\" y=\"20\" fill=\"#c0392b\" font-family=\"sans-serif\" font-size=\"12\">before (nominal)</text>\n\
         <text x=\"{}\" y=\"20\" fill=\"#2471a3\" font-family=\"sans-serif\" font-size=\"12\">after (identified)</text>\n</svg>\n",
        w - 260.0,
        w - 140.0
    );
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chart_scales_the_largest_value_to_the_top() {
        let s = error_chart("a < b", &[0.002, 0.004], &[0.001, 0.0]);
        assert!(s.starts_with("<svg") && s.trim_end().ends_with("</svg>"));
        assert!(s.contains("a &lt; b"));
        // 4 µm is the top (y = 30), 0 the bottom (y = 360); x from 60 to 780.
        assert!(s.contains("points=\"60.00,195.00 780.00,30.00\""), "{s}");
        assert!(s.contains("points=\"60.00,277.50 780.00,360.00\""));
        assert!(s.contains("4.0 µm"));
    }
}
