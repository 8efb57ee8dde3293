//! Circular-test section (ISO 230-4) from the JSON of `mtwin ballbar
//! circular --format json`: G, H, F, the ranked diagnosis and the polar plot
//! of the traces the document keeps.

use super::fmt;
use crate::methods::ballbar::circular::{CircularDoc, plot_svg};
use crate::report::html::{Block, Section, Table, Verdict};

/// The circular-test section; the polar plot ([`plot_svg`]) when the
/// document has its traces.
pub fn section(doc: &CircularDoc) -> Section {
    let plane = doc.plane.as_str().to_uppercase();
    let mut s = Section::new(
        &format!("circular-{}", doc.plane.as_str()),
        &format!("Circular test in {plane} (ISO 230-4)"),
    );
    s.push(Block::Text(format!(
        "Ballbar circle of radius {} mm in the {plane} plane ({}). G circular deviation, H circular \
         hysteresis, F radial deviation; the diagnosis fits the signature of each error to both \
         traces by least squares (docs/ballbar.md).",
        crate::io::fmt_f64(doc.radius_mm),
        doc.directions.join(" + ")
    )));
    let mut t = Table::new("ISO 230-4 figures (µm)", &["figure", "value"]);
    t.row(vec!["circular deviation G".into(), fmt(Some(doc.g_um), 2)]);
    t.row(vec!["circular hysteresis H".into(), fmt(doc.h_um, 2)]);
    t.row(vec![
        "radial deviation F (min … max)".into(),
        format!(
            "{} ({} … {})",
            fmt(Some(doc.f_um), 2),
            fmt(Some(doc.f_min_um), 2),
            fmt(Some(doc.f_max_um), 2)
        ),
    ]);
    s.push(Block::Table(t));
    let mut d = Table::new(
        "Diagnosis, largest signature first",
        &[
            "key",
            "value",
            "± (standard uncertainty)",
            "peak on the trace (µm)",
        ],
    );
    for r in &doc.ranking {
        d.row(vec![
            r.key.clone(),
            fmt(Some(r.value), 2),
            fmt(Some(r.uncertainty), 2),
            fmt(Some(r.peak_um), 2),
        ]);
    }
    s.push(Block::Table(d));
    if !doc.traces.is_empty() {
        s.push(Block::Figure {
            caption:
                "Δr of each direction about the fitted centre (µm rings; 0 the nominal circle)."
                    .into(),
            svg: plot_svg(doc),
        });
    }
    let lines: Vec<String> = doc
        .inseparable
        .iter()
        .map(|g| format!("{} cannot be told apart in this set-up", g.join(" and ")))
        .collect();
    s.push(Block::Verdict {
        verdict: if lines.is_empty() {
            Verdict::Good
        } else {
            Verdict::Caution
        },
        title: if lines.is_empty() {
            format!(
                "Every diagnostic is separable; residual RMS {} µm.",
                fmt(Some(doc.residual_rms_um), 2)
            )
        } else {
            "Not reported (not guessed):".into()
        },
        lines,
    });
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::methods::ballbar::circular::{CircularOptions, Plane, circular};
    use crate::methods::ballbar::circular_sim::{CircularErrors, simulate_circular};

    #[test]
    fn ranking_and_plot_in_the_section() {
        let e = CircularErrors {
            backlash_x_um: 8.0,
            ..Default::default()
        };
        let o = CircularOptions {
            radius_mm: 150.0,
            plane: Plane::Zx,
            ..Default::default()
        };
        let cw = simulate_circular(&e, &o, false, 720, 0.0, 1);
        let ccw = simulate_circular(&e, &o, true, 720, 0.0, 1);
        let doc = circular(Some(&cw), Some(&ccw), &o).unwrap();
        let s = section(&doc);
        let html = crate::report::html::render(&crate::report::html::Report {
            title: "t".into(),
            subtitle: String::new(),
            sections: vec![s],
        });
        // the first axis of ZX is z: the backlash put in is `backlash_z_um`
        assert!(html.contains("Circular test in ZX") && html.contains("backlash_z_um"));
        assert!(html.contains("<svg"));
        let at = html.find("backlash_z_um").unwrap();
        let row = &html[at..at + html[at..].find("</tr>").unwrap()];
        // the value cell: 8 µm put in, within 5 %
        let v: f64 = row
            .split("<td class=\"n\">")
            .nth(1)
            .and_then(|c| c.split('<').next())
            .and_then(|c| c.parse().ok())
            .unwrap_or_else(|| panic!("{row}"));
        assert!((v - 8.0).abs() <= 0.4, "{row}");
    }

    /// The report drawn from the document alone (read back from its JSON):
    /// each polyline of the polar plot is the document's trace, about the
    /// fitted centre, at the scale `svg::polar` documents — recomputed here.
    #[test]
    fn polar_plot_from_the_json_document_at_the_documented_scale() {
        let e = CircularErrors {
            backlash_x_um: 5.0,
            squareness_um_per_m: 20.0,
            centre_x_um: 3.0,
            centre_y_um: -2.0,
            ..Default::default()
        };
        let o = CircularOptions {
            radius_mm: 100.0,
            ..Default::default()
        };
        let cw = simulate_circular(&e, &o, false, 3600, 0.1, 4);
        let ccw = simulate_circular(&e, &o, true, 3600, 0.1, 4);
        let doc = circular(Some(&cw), Some(&ccw), &o).unwrap();
        let json = serde_json::to_string(&doc).unwrap();
        let back: CircularDoc = serde_json::from_str(&json).unwrap();
        assert_eq!(back, doc);
        let html = crate::report::html::render(&crate::report::html::Report {
            title: "t".into(),
            subtitle: String::new(),
            sections: vec![section(&back)],
        });
        let lines: Vec<Vec<(f64, f64)>> = html
            .split("<polyline")
            .skip(1)
            .map(|p| {
                let pts = p
                    .split("points=\"")
                    .nth(1)
                    .unwrap()
                    .split('"')
                    .next()
                    .unwrap();
                pts.split(' ')
                    .map(|xy| {
                        let (x, y) = xy.split_once(',').unwrap();
                        (x.parse().unwrap(), y.parse().unwrap())
                    })
                    .collect()
            })
            .collect();
        assert_eq!(lines.len(), 2, "one polyline per direction");
        // expected points: Δr − cx cos θ − cy sin θ, sorted, closed at +360°
        let (cx, cy) = (
            back.get("centre_x_um").unwrap(),
            back.get("centre_y_um").unwrap(),
        );
        assert!((cx - 3.0).abs() < 0.1 && (cy + 2.0).abs() < 0.1);
        let curves: Vec<Vec<(f64, f64)>> = back
            .traces
            .iter()
            .map(|t| {
                let mut v: Vec<(f64, f64)> = (0..t.angle_deg.len())
                    .map(|i| {
                        let a = t.angle_deg[i].rem_euclid(360.0);
                        let r = a.to_radians();
                        (a, t.deviation_um[i] - cx * r.cos() - cy * r.sin())
                    })
                    .collect();
                v.sort_by(|p, q| p.0.partial_cmp(&q.0).unwrap());
                v.push((v[0].0 + 360.0, v[0].1));
                v
            })
            .collect();
        let vmax = curves
            .iter()
            .flatten()
            .map(|p| p.1.abs())
            .fold(0.0, f64::max);
        // the scale: the smallest 1, 2, 5 × 10ⁿ not below the largest |Δr|
        let dec = 10f64.powf(vmax.log10().floor());
        let v = [1.0, 2.0, 5.0, 10.0]
            .iter()
            .map(|m| m * dec)
            .find(|&c| c >= vmax)
            .unwrap();
        // a 480 px plot: centre (240, 250), outer radius 190 px
        for (line, curve) in lines.iter().zip(&curves) {
            assert_eq!(line.len(), curve.len());
            for (&(x, y), &(a, d)) in line.iter().zip(curve) {
                let rho = 190.0 * (0.5 + 0.45 * d / v);
                let (ex, ey) = (
                    240.0 + rho * a.to_radians().cos(),
                    250.0 - rho * a.to_radians().sin(),
                );
                assert!(
                    (x - ex).abs() <= 0.006 && (y - ey).abs() <= 0.006,
                    "({x}, {y}) vs ({ex}, {ey})"
                );
            }
        }
    }

    /// The document keeps every ⌈n/720⌉-th sample, rounded to 0.001.
    #[test]
    fn traces_are_decimated_to_at_most_720_points() {
        use crate::methods::ballbar::circular::{DocTrace, TRACE_POINTS_MAX, Trace};
        assert_eq!(TRACE_POINTS_MAX, 720);
        for (n, stride, kept) in [(720, 1, 720), (721, 2, 361), (3600, 5, 720), (10, 1, 10)] {
            let t = Trace {
                angle_deg: (0..n).map(|i| 360.0 * i as f64 / n as f64).collect(),
                deviation_um: (0..n).map(|i| (i as f64 * 0.37).sin() * 4.0).collect(),
            };
            let d = DocTrace::decimate("ccw", &t);
            assert_eq!((d.stride, d.angle_deg.len()), (stride, kept), "n = {n}");
            for (k, (&a, &r)) in d.angle_deg.iter().zip(&d.deviation_um).enumerate() {
                let i = k * stride;
                assert!(
                    (a - t.angle_deg[i]).abs() <= 5e-4 && (r - t.deviation_um[i]).abs() <= 5e-4
                );
            }
        }
    }
}
