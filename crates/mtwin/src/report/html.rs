//! A self-contained HTML report: inline CSS, inline SVG figures, no script and
//! no external resource, so the file opens offline in any browser.
//!
//! A [`Report`] is a list of [`Section`]s, each a list of [`Block`]s (text,
//! headline figures, tables, figures, an identifiability verdict). The
//! per-method builders in [`crate::report::sections`] fill them; [`render`]
//! turns the whole into one HTML string.

use std::fmt::Write as _;

use super::sanitize::sanitize_svg;

/// A whole report.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Report {
    /// Page title.
    pub title: String,
    /// One line under the title (what was run, on what).
    pub subtitle: String,
    /// The sections, in page order.
    pub sections: Vec<Section>,
}

/// One section (one method or one input file).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Section {
    /// Anchor (letters, digits, `-`).
    pub id: String,
    /// Heading.
    pub title: String,
    /// Content, in page order.
    pub blocks: Vec<Block>,
}

impl Section {
    /// An empty section.
    pub fn new(id: &str, title: &str) -> Section {
        Section {
            id: id.to_string(),
            title: title.to_string(),
            blocks: Vec::new(),
        }
    }

    /// Appends a block (builder style).
    pub fn with(mut self, b: Block) -> Section {
        self.blocks.push(b);
        self
    }

    /// Appends a block.
    pub fn push(&mut self, b: Block) {
        self.blocks.push(b);
    }

    /// Number of figures in the section.
    pub fn figures(&self) -> usize {
        self.blocks
            .iter()
            .filter(|b| matches!(b, Block::Figure { .. }))
            .count()
    }
}

/// A figure compared with the source's own (docs/references.md).
#[derive(Debug, Clone, PartialEq)]
pub struct Headline {
    /// What is measured, e.g. "largest position error after compensation".
    pub label: String,
    /// Our value with its unit, e.g. "4.2 µm".
    pub ours: String,
    /// The source's value with its unit, e.g. "5.1 µm".
    pub source: String,
}

/// A table; every header cell names its unit.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Table {
    /// Caption above the table.
    pub caption: String,
    /// Header cells (each names its unit).
    pub header: Vec<String>,
    /// Body rows, one cell per header cell.
    pub rows: Vec<Vec<String>>,
}

impl Table {
    /// A table with a caption and header cells.
    pub fn new(caption: &str, header: &[&str]) -> Table {
        Table {
            caption: caption.to_string(),
            header: header.iter().map(|s| s.to_string()).collect(),
            rows: Vec::new(),
        }
    }

    /// Appends a row.
    pub fn row(&mut self, cells: Vec<String>) {
        self.rows.push(cells);
    }
}

/// How a verdict reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Verdict {
    /// Everything asked for is determined.
    Good,
    /// Determined with reservations (some parameters not identifiable, warnings).
    Caution,
    /// The result should not be used.
    Bad,
}

/// One piece of a section.
#[derive(Debug, Clone, PartialEq)]
pub enum Block {
    /// A paragraph of plain text.
    Text(String),
    /// Our figures beside the sources'.
    Headlines(Vec<Headline>),
    /// A table.
    Table(Table),
    /// An inline SVG document (from [`crate::report::svg`]) with a caption.
    Figure {
        /// Caption under the figure.
        caption: String,
        /// The SVG document.
        svg: String,
    },
    /// An identifiability or quality verdict with its explanation lines.
    Verdict {
        /// How it reads.
        verdict: Verdict,
        /// One-line summary.
        title: String,
        /// Explanation, one line each.
        lines: Vec<String>,
    },
}

/// Escapes text for HTML.
pub fn escape(s: &str) -> String {
    let mut o = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => o.push_str("&amp;"),
            '<' => o.push_str("&lt;"),
            '>' => o.push_str("&gt;"),
            '"' => o.push_str("&quot;"),
            '\'' => o.push_str("&#39;"),
            c => o.push(c),
        }
    }
    o
}

/// An SVG document made safe to inline by [`sanitize_svg`]: parsed as XML and
/// written again with only allowlisted elements and attributes. What was removed
/// is listed in a note under the figure; a document that cannot be parsed, or
/// that is not SVG, is left out with a note saying why.
fn inline_svg(svg: &str) -> String {
    match sanitize_svg(svg) {
        Ok(d) if d.dropped.is_empty() => d.svg,
        Ok(d) => format!(
            "{}<p class=\"note\">(removed from this figure: {})</p>",
            d.svg,
            escape(&d.dropped.join(", "))
        ),
        Err(e) => format!(
            "<p class=\"note\">(figure left out: {})</p>",
            escape(&e.to_string())
        ),
    }
}

const CSS: &str = "
body{font-family:system-ui,-apple-system,'Segoe UI',sans-serif;margin:0;color:#1b2631;background:#f4f6f7;line-height:1.45}
header{background:#1b2631;color:#fff;padding:18px 32px}
header h1{margin:0;font-size:24px}
header p{margin:4px 0 0;color:#d5dbdb}
nav{padding:8px 32px;background:#e5e8e8;font-size:14px}
nav a{margin-right:14px;color:#1f618d;text-decoration:none}
main{padding:8px 32px 40px;max-width:1200px}
section{background:#fff;border-radius:6px;padding:12px 24px 20px;margin:18px 0;box-shadow:0 1px 3px rgba(0,0,0,.12)}
h2{margin:8px 0 12px;font-size:20px;border-bottom:2px solid #d6eaf8;padding-bottom:4px}
table{border-collapse:collapse;margin:10px 0 16px;font-size:13px}
caption{text-align:left;font-weight:600;padding:4px 0}
th,td{border:1px solid #d5d8dc;padding:3px 8px}
th{background:#eaf2f8;text-align:left}
td.n{text-align:right;font-variant-numeric:tabular-nums}
.scroll{max-height:420px;overflow:auto;display:inline-block}
.headlines{display:flex;flex-wrap:wrap;gap:12px;margin:10px 0}
.headline{border:1px solid #d5d8dc;border-radius:6px;padding:8px 14px;min-width:220px}
.headline .label{font-size:12px;color:#566573}
.headline .ours{font-size:22px;font-weight:600;color:#1f618d}
.headline .source{font-size:12px;color:#566573}
.verdict{border-left:6px solid;padding:6px 14px;margin:10px 0;background:#fbfcfc}
.verdict.good{border-color:#27ae60}.verdict.caution{border-color:#f39c12}.verdict.bad{border-color:#c0392b}
.verdict ul{margin:4px 0;padding-left:20px;font-size:13px}
figure{display:inline-block;margin:8px 12px 8px 0;vertical-align:top}
figure svg{max-width:100%;height:auto;border:1px solid #e5e8e8}
figcaption{font-size:12px;color:#566573;max-width:560px}
.note{color:#566573;font-size:13px}
footer{color:#566573;font-size:12px;padding:0 32px 24px}
";

fn looks_numeric(s: &str) -> bool {
    let t = s.trim_start_matches(['±', '−', '-', '+', ' ']);
    t.chars().next().is_some_and(|c| c.is_ascii_digit())
}

fn render_table(o: &mut String, t: &Table) {
    let long = t.rows.len() > 16;
    if long {
        o.push_str("<div class=\"scroll\">");
    }
    o.push_str("<table>");
    if !t.caption.is_empty() {
        let _ = write!(o, "<caption>{}</caption>", escape(&t.caption));
    }
    o.push_str("<thead><tr>");
    for h in &t.header {
        let _ = write!(o, "<th>{}</th>", escape(h));
    }
    o.push_str("</tr></thead><tbody>");
    for r in &t.rows {
        o.push_str("<tr>");
        for c in r {
            let class = if looks_numeric(c) { " class=\"n\"" } else { "" };
            let _ = write!(o, "<td{class}>{}</td>", escape(c));
        }
        o.push_str("</tr>");
    }
    o.push_str("</tbody></table>");
    if long {
        o.push_str("</div>");
    }
    o.push('\n');
}

fn render_block(o: &mut String, b: &Block) {
    match b {
        Block::Text(t) => {
            let _ = writeln!(o, "<p>{}</p>", escape(t));
        }
        Block::Headlines(hs) => {
            o.push_str("<div class=\"headlines\">");
            for h in hs {
                let _ = write!(
                    o,
                    "<div class=\"headline\"><div class=\"label\">{}</div><div class=\"ours\">{}</div><div class=\"source\">source: {}</div></div>",
                    escape(&h.label),
                    escape(&h.ours),
                    escape(&h.source)
                );
            }
            o.push_str("</div>\n");
        }
        Block::Table(t) => render_table(o, t),
        Block::Figure { caption, svg } => {
            let _ = writeln!(
                o,
                "<figure>{}<figcaption>{}</figcaption></figure>",
                inline_svg(svg),
                escape(caption)
            );
        }
        Block::Verdict {
            verdict,
            title,
            lines,
        } => {
            let class = match verdict {
                Verdict::Good => "good",
                Verdict::Caution => "caution",
                Verdict::Bad => "bad",
            };
            let _ = write!(
                o,
                "<div class=\"verdict {class}\"><strong>{}</strong>",
                escape(title)
            );
            if !lines.is_empty() {
                o.push_str("<ul>");
                for l in lines {
                    let _ = write!(o, "<li>{}</li>", escape(l));
                }
                o.push_str("</ul>");
            }
            o.push_str("</div>\n");
        }
    }
}

/// The report as one self-contained HTML document.
pub fn render(r: &Report) -> String {
    let mut o = String::with_capacity(64 * 1024);
    let _ = write!(
        o,
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\
         <meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\
         <title>{}</title><style>{CSS}</style></head><body>\n",
        escape(&r.title)
    );
    let _ = writeln!(
        o,
        "<header><h1>{}</h1><p>{}</p></header>",
        escape(&r.title),
        escape(&r.subtitle)
    );
    o.push_str("<nav>");
    for s in &r.sections {
        let _ = write!(o, "<a href=\"#{}\">{}</a>", escape(&s.id), escape(&s.title));
    }
    o.push_str("</nav>\n<main>\n");
    for s in &r.sections {
        let _ = writeln!(
            o,
            "<section id=\"{}\"><h2>{}</h2>",
            escape(&s.id),
            escape(&s.title)
        );
        for b in &s.blocks {
            render_block(&mut o, b);
        }
        o.push_str("</section>\n");
    }
    let _ = writeln!(
        o,
        "</main><footer>Written by mtwin {}. Units: mm, µm, rad, µrad, degrees for rotary axis positions, s, min, rev/min — as labelled.</footer></body></html>",
        env!("CARGO_PKG_VERSION")
    );
    o
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn text_is_escaped_and_figures_are_inlined() {
        let r = Report {
            title: "a <b> & c".into(),
            subtitle: String::new(),
            sections: vec![
                Section::new("s1", "One")
                    .with(Block::Text("x < y".into()))
                    .with(Block::Figure {
                    caption: "fig".into(),
                    svg: "<?xml version=\"1.0\"?><svg xmlns=\"http://www.w3.org/2000/svg\"></svg>"
                        .into(),
                }),
            ],
        };
        let h = render(&r);
        assert!(h.contains("<title>a &lt;b&gt; &amp; c</title>"));
        assert!(h.contains("<p>x &lt; y</p>"));
        assert!(h.contains("<figure><svg xmlns"));
        assert!(!h.contains("<?xml"));
        assert!(h.contains("href=\"#s1\""));
        // Self-contained: no script, no external fetch.
        assert!(!h.contains("<script"));
        for fetch in ["src=", "<link", "https://", "url("] {
            assert!(!h.contains(fetch), "{fetch}");
        }
    }

    #[test]
    fn unsafe_svg_is_cleaned_or_left_out() {
        for bad in [
            "<svg><script>alert(1)</script></svg>",
            "<svg onload=\"alert(1)\"></svg>",
            "<svg><image href=\"http://x/y.png\"/></svg>",
            "<svg xmlns=\"http://www.w3.org/2000/svg\"\nonload=\"alert(1)\"/>",
            "<svg><use href=\"javascript:alert(1)\"/></svg>",
        ] {
            let h = inline_svg(bad);
            let (svg, note) = h
                .split_once("<p class=\"note\">(removed from this figure: ")
                .unwrap();
            assert!(svg.starts_with("<svg") && svg.ends_with(">"), "{svg}");
            for gone in ["script", "alert", "http://x", "onload="] {
                assert!(!svg.contains(gone), "{gone} in {svg}");
            }
            // The note names what went, escaped.
            assert!(
                !note.contains("<script") && note.ends_with(")</p>"),
                "{note}"
            );
        }
        // Not XML (an HTML parser would run this handler): left out, with the reason.
        let h = inline_svg("<svg/onload=alert(1)>");
        assert!(h.starts_with("<p class=\"note\">(figure left out: it is not well-formed XML"));
        assert!(!h.contains("<svg"));
        assert!(inline_svg("<p>no</p>").contains("root element is &lt;p&gt;"));
        assert_eq!(
            inline_svg("<svg font-size=\"12\"><text>one</text></svg>"),
            "<svg xmlns=\"http://www.w3.org/2000/svg\" font-size=\"12\"><text>one</text></svg>"
        );
    }

    #[test]
    fn numeric_cells_are_right_aligned() {
        let mut t = Table::new("c", &["name", "value (µm)"]);
        t.row(vec!["EXX".into(), "−1.5".into()]);
        let mut o = String::new();
        render_table(&mut o, &t);
        assert!(o.contains("<td>EXX</td><td class=\"n\">−1.5</td>"));
    }
}
