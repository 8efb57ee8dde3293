//! Making a user-supplied SVG document safe to inline in the HTML report.
//!
//! The document is parsed by an XML parser (`roxmltree`) and written again
//! from the parsed tree, keeping only an allowlist of SVG elements and
//! attributes: the shapes, text and grouping that plots use and the common
//! presentation attributes. Scripts, `foreignObject`, `style` elements,
//! images, links, animations, event attributes (`onload`, …), `href`s other
//! than a same-document `#id`, and `url(…)` references other than `url(#id)`
//! are dropped, with the rest of the figure kept. Comments, processing
//! instructions and the DOCTYPE are not written. Text and attribute values
//! are escaped on output, so nothing in the input is copied verbatim.

use std::collections::BTreeSet;
use std::fmt::Write as _;

use super::html::escape;

/// The SVG namespace.
const SVG_NS: &str = "http://www.w3.org/2000/svg";
/// The XLink namespace (`xlink:href`).
const XLINK_NS: &str = "http://www.w3.org/1999/xlink";
/// The XML namespace (`xml:space`).
const XML_NS: &str = "http://www.w3.org/XML/1998/namespace";

/// Elements written again (with their allowed attributes and allowed children).
const ELEMENTS: &[&str] = &[
    "svg",
    "g",
    "defs",
    "symbol",
    "use",
    "title",
    "desc",
    "line",
    "polyline",
    "polygon",
    "path",
    "rect",
    "circle",
    "ellipse",
    "text",
    "tspan",
    "linearGradient",
    "radialGradient",
    "stop",
    "clipPath",
    "marker",
];

/// Attributes without a namespace that are written again (values still checked).
const ATTRIBUTES: &[&str] = &[
    // identity and geometry
    "id",
    "class",
    "x",
    "y",
    "x1",
    "y1",
    "x2",
    "y2",
    "cx",
    "cy",
    "r",
    "rx",
    "ry",
    "fx",
    "fy",
    "width",
    "height",
    "viewBox",
    "preserveAspectRatio",
    "version",
    "points",
    "d",
    "transform",
    "pathLength",
    // presentation
    "style",
    "fill",
    "fill-opacity",
    "fill-rule",
    "clip-rule",
    "stroke",
    "stroke-width",
    "stroke-opacity",
    "stroke-dasharray",
    "stroke-dashoffset",
    "stroke-linecap",
    "stroke-linejoin",
    "stroke-miterlimit",
    "opacity",
    "color",
    "display",
    "visibility",
    "vector-effect",
    "shape-rendering",
    "text-rendering",
    "paint-order",
    "clip-path",
    "marker-start",
    "marker-mid",
    "marker-end",
    // text
    "font-family",
    "font-size",
    "font-weight",
    "font-style",
    "font-variant",
    "text-anchor",
    "text-decoration",
    "dominant-baseline",
    "alignment-baseline",
    "baseline-shift",
    "letter-spacing",
    "word-spacing",
    "writing-mode",
    "dx",
    "dy",
    "rotate",
    "textLength",
    "lengthAdjust",
    // gradients, clip paths and markers
    "offset",
    "stop-color",
    "stop-opacity",
    "gradientUnits",
    "gradientTransform",
    "spreadMethod",
    "clipPathUnits",
    "markerWidth",
    "markerHeight",
    "markerUnits",
    "refX",
    "refY",
    "orient",
    // a same-document reference only (checked)
    "href",
];

/// An SVG document made safe to inline.
#[derive(Debug, Clone, PartialEq)]
pub struct SafeSvg {
    /// The `<svg>` element and its allowed content, re-serialised.
    pub svg: String,
    /// What was dropped, each named once (`element <script>`, `attribute onload`, …), sorted.
    pub dropped: Vec<String>,
}

/// Why a document could not be inlined at all.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum SvgError {
    /// Not well-formed XML.
    #[error("it is not well-formed XML ({0})")]
    Xml(String),
    /// Well-formed, but the root element is not `<svg>`.
    #[error("its root element is <{0}>, not <svg>")]
    NotSvg(String),
}

/// Parse `text` as an SVG document and write it again with only the allowlisted
/// elements and attributes (see the module documentation).
pub fn sanitize_svg(text: &str) -> Result<SafeSvg, SvgError> {
    let opts = roxmltree::ParsingOptions {
        // A DOCTYPE is common in SVG files; roxmltree bounds entity expansion.
        allow_dtd: true,
        nodes_limit: 2_000_000,
    };
    let doc = roxmltree::Document::parse_with_options(text, opts)
        .map_err(|e| SvgError::Xml(e.to_string()))?;
    let root = doc.root_element();
    if !is_svg(root) || root.tag_name().name() != "svg" {
        return Err(SvgError::NotSvg(root.tag_name().name().to_string()));
    }
    let mut w = Writer {
        out: String::with_capacity(text.len()),
        dropped: BTreeSet::new(),
    };
    w.element(root, true);
    Ok(SafeSvg {
        svg: w.out,
        dropped: w.dropped.into_iter().collect(),
    })
}

/// An element in the SVG namespace, or in no namespace (SVG written without `xmlns`).
fn is_svg(n: roxmltree::Node) -> bool {
    matches!(n.tag_name().namespace(), None | Some(SVG_NS))
}

struct Writer {
    out: String,
    dropped: BTreeSet<String>,
}

impl Writer {
    fn element(&mut self, n: roxmltree::Node, root: bool) {
        let name = n.tag_name().name();
        if !is_svg(n) || !ELEMENTS.contains(&name) {
            self.dropped.insert(format!("element <{name}>"));
            return;
        }
        let _ = write!(self.out, "<{name}");
        if root {
            let _ = write!(self.out, " xmlns=\"{SVG_NS}\"");
            let uses_xlink = n
                .descendants()
                .any(|d| d.attributes().any(|a| a.namespace() == Some(XLINK_NS)));
            if uses_xlink {
                let _ = write!(self.out, " xmlns:xlink=\"{XLINK_NS}\"");
            }
        }
        for a in n.attributes() {
            let (aname, value) = (a.name(), a.value());
            let written = match a.namespace() {
                None if ATTRIBUTES.contains(&aname) => aname.to_string(),
                Some(XLINK_NS) if aname == "href" => "xlink:href".to_string(),
                Some(XML_NS) if aname == "space" => "xml:space".to_string(),
                _ => {
                    self.dropped.insert(format!("attribute {aname}"));
                    continue;
                }
            };
            let ok = if aname == "href" {
                same_document_ref(value)
            } else if aname == "style" {
                safe_style(value)
            } else {
                safe_value(value)
            };
            if !ok {
                self.dropped
                    .insert(format!("attribute {aname}=\"{value}\""));
                continue;
            }
            let _ = write!(self.out, " {written}=\"{}\"", escape(value));
        }
        let children: Vec<_> = n
            .children()
            .filter(|c| c.is_element() || c.is_text())
            .collect();
        if children.is_empty() {
            self.out.push_str("/>");
            return;
        }
        self.out.push('>');
        for c in children {
            if c.is_element() {
                self.element(c, false);
            } else if let Some(t) = c.text() {
                self.out.push_str(&escape(t));
            }
        }
        let _ = write!(self.out, "</{name}>");
    }
}

/// `#id`, the only link kept: a reference inside the same document.
fn same_document_ref(v: &str) -> bool {
    let v = v.trim();
    v.len() > 1
        && v.starts_with('#')
        && v[1..]
            .chars()
            .all(|c| c.is_alphanumeric() || matches!(c, '-' | '_' | '.' | ':'))
}

/// A value whose every `url(…)` is `url(#id)` and that names no script scheme.
fn safe_value(v: &str) -> bool {
    let lower: String = v
        .chars()
        .filter(|c| !c.is_whitespace())
        .collect::<String>()
        .to_ascii_lowercase();
    if lower.contains("javascript:") || lower.contains("data:") || lower.contains("expression(") {
        return false;
    }
    lower.match_indices("url(").all(|(i, _)| {
        let rest = lower[i + 4..].trim_start_matches(['"', '\'']);
        rest.starts_with('#')
    })
}

/// A `style` attribute: [`safe_value`], and no CSS escapes, comments or at-rules
/// that could hide a URL from that check.
fn safe_style(v: &str) -> bool {
    safe_value(v) && !v.contains(['\\', '@']) && !v.contains("/*")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::report::svg::{Series, bars, polar, xy};

    fn names(d: &SafeSvg) -> String {
        d.dropped.join("; ")
    }

    /// Each element as (name, sorted attributes, own text), in document order.
    type Flat = Vec<(String, Vec<(String, String)>, String)>;

    fn flatten(svg: &str) -> Flat {
        let doc = roxmltree::Document::parse(svg).unwrap_or_else(|e| panic!("{e}\n{svg}"));
        doc.root_element()
            .descendants()
            .filter(|n| n.is_element())
            .map(|n| {
                let mut attrs: Vec<(String, String)> = n
                    .attributes()
                    .map(|a| (a.name().to_string(), a.value().to_string()))
                    .collect();
                attrs.sort();
                let text: String = n
                    .children()
                    .filter(|c| c.is_text())
                    .filter_map(|c| c.text())
                    .collect();
                (
                    n.tag_name().name().to_string(),
                    attrs,
                    text.trim().to_string(),
                )
            })
            .collect()
    }

    #[test]
    fn the_three_bypasses_of_the_string_check_are_removed() {
        // `<svg/onload=…>` is not well-formed XML: the figure is left out.
        assert!(matches!(
            sanitize_svg("<svg/onload=alert(1)>"),
            Err(SvgError::Xml(_))
        ));
        // The well-formed spelling of the same thing loses the handler.
        let d = sanitize_svg("<svg onload=\"alert(1)\"/>").unwrap();
        assert_eq!(d.svg, format!("<svg xmlns=\"{SVG_NS}\"/>"));
        assert_eq!(names(&d), "attribute onload");
        // A newline (or tab) before `onload`.
        let d = sanitize_svg("<svg xmlns=\"http://www.w3.org/2000/svg\"\nonload=\"alert(1)\"><rect\tonclick=\"x()\" width=\"5\"/></svg>").unwrap();
        assert!(!d.svg.contains("on"), "{}", d.svg);
        assert!(d.svg.contains("<rect width=\"5\"/>"));
        assert_eq!(names(&d), "attribute onclick; attribute onload");
        // `href="javascript:`, in an allowed element (`use`) and in a dropped one (`a`).
        let d = sanitize_svg(
            "<svg xmlns=\"http://www.w3.org/2000/svg\" xmlns:xlink=\"http://www.w3.org/1999/xlink\">\
             <use href=\"javascript:alert(1)\"/><use xlink:href=\" JavaScript:alert(1)\"/>\
             <a href=\"javascript:alert(1)\"><text>click</text></a></svg>",
        )
        .unwrap();
        assert!(!d.svg.to_lowercase().contains("javascript"), "{}", d.svg);
        assert!(!d.svg.contains("click"));
        assert_eq!(d.svg.matches("<use/>").count(), 2, "{}", d.svg);
    }

    #[test]
    fn scripts_foreign_content_external_references_and_styles_are_dropped() {
        let d = sanitize_svg(
            "<?xml version=\"1.0\"?>\n<!DOCTYPE svg>\n<!-- c -->\
             <svg xmlns=\"http://www.w3.org/2000/svg\" xmlns:h=\"http://www.w3.org/1999/xhtml\">\
             <script>alert(1)</script><SCRIPT>alert(2)</SCRIPT>\
             <foreignObject><h:iframe src=\"http://x\"/></foreignObject>\
             <style>@import url(http://x/y.css);</style>\
             <image href=\"http://x/y.png\"/>\
             <animate attributeName=\"href\" to=\"javascript:alert(1)\"/>\
             <h:script>alert(3)</h:script>\
             <rect fill=\"url(http://x/p#a)\" stroke=\"url(#grad)\" width=\"2\"/>\
             <circle style=\"fill:url( 'https://x' )\" r=\"1\"/>\
             <circle style=\"fill:red;stroke:blue\" r=\"2\"/>\
             <circle style=\"background:u\\72l(http://x)\" r=\"3\"/>\
             <use href=\"#grad\"/><use href=\"other.svg#a\"/>\
             <text x=\"1\">a &lt;b&gt; &amp; c</text></svg>",
        )
        .unwrap();
        let s = &d.svg;
        for gone in [
            "script",
            "alert",
            "foreignObject",
            "iframe",
            "import",
            "http://x",
            "image",
            "animate",
            "other.svg",
            "u\\72l",
            "<!--",
            "DOCTYPE",
            "<?xml",
        ] {
            assert!(!s.contains(gone), "{gone} in {s}");
        }
        assert!(
            s.contains("<rect stroke=\"url(#grad)\" width=\"2\"/>"),
            "{s}"
        );
        assert!(s.contains("<circle r=\"1\"/>"), "{s}");
        assert!(
            s.contains("<circle style=\"fill:red;stroke:blue\" r=\"2\"/>"),
            "{s}"
        );
        assert!(s.contains("<use href=\"#grad\"/><use/>"), "{s}");
        assert!(
            s.contains("<text x=\"1\">a &lt;b&gt; &amp; c</text>"),
            "{s}"
        );
        for name in [
            "element <script>",
            "element <SCRIPT>",
            "element <foreignObject>",
            "element <style>",
            "element <image>",
            "element <animate>",
        ] {
            assert!(d.dropped.iter().any(|x| x == name), "{name}: {}", names(&d));
        }
    }

    #[test]
    fn documents_that_are_not_svg_are_refused() {
        assert!(matches!(sanitize_svg("not xml"), Err(SvgError::Xml(_))));
        assert!(matches!(
            sanitize_svg("<svg><g></svg>"),
            Err(SvgError::Xml(_))
        ));
        assert_eq!(
            sanitize_svg("<html><svg/></html>"),
            Err(SvgError::NotSvg("html".into()))
        );
        // An <svg> in another namespace is not SVG.
        assert!(matches!(
            sanitize_svg("<svg xmlns=\"http://example.com/x\"/>"),
            Err(SvgError::NotSvg(_))
        ));
        // Entity expansion is bounded by the parser (billion laughs).
        let mut lol = String::from("<!DOCTYPE svg [<!ENTITY a \"aaaaaaaaaa\">");
        for i in 1..10 {
            let p = (b'a' + i - 1) as char;
            let c = (b'a' + i) as char;
            let _ = write!(lol, "<!ENTITY {c} \"{}\">", format!("&{p};").repeat(10));
        }
        lol.push_str("]><svg><text>&j;</text></svg>");
        assert!(sanitize_svg(&lol).is_err());
    }

    #[test]
    fn every_plot_mtwin_draws_survives_unchanged() {
        let ring: Vec<(f64, f64)> = (0..36)
            .map(|i| (10.0 * i as f64, (i as f64 * 0.3).sin() * 1e-3))
            .collect();
        let series = vec![
            Series {
                name: "measured <run> & \"1\"".into(),
                points: ring.clone(),
                color: "#1f618d".into(),
                markers: true,
            },
            Series {
                name: "model".into(),
                points: ring,
                color: "#c0392b".into(),
                markers: false,
            },
        ];
        let pts: Vec<[f64; 3]> = (0..50)
            .map(|i| {
                let t = i as f64 * 0.1;
                [t.cos() * 50.0, t.sin() * 50.0, t]
            })
            .collect();
        let errs: Vec<f64> = (0..50).map(|i| i as f64 * 1e-4).collect();
        let plots = [
            polar("polar <title>", &series, "µm", 1e3),
            xy("xy", "x, mm", "y, µm", &series),
            bars(
                "bars",
                "µm",
                &["X".into(), "Y".into()],
                &[
                    ("a".into(), "#111".into(), vec![1.0, -2.0]),
                    ("b".into(), "#222".into(), vec![0.5, f64::NAN]),
                ],
            ),
            crate::report::path3d::coloured_path("path", &pts, &pts, &errs, "ε_p, µm", 1e3),
        ];
        for svg in &plots {
            let d = sanitize_svg(svg).unwrap();
            assert!(d.dropped.is_empty(), "{}", names(&d));
            let (a, b) = (flatten(svg), flatten(&d.svg));
            assert!(a.len() > 5);
            assert_eq!(a, b);
        }
    }
}
