//! Reports: hand-written SVG plots ([`svg`]), the self-contained HTML page
//! ([`html`]) and one builder per method ([`sections`]) that turns a
//! command's result (its `--format json` document, a model file or an output
//! CSV) into a report section.

pub mod html;
pub mod path3d;
pub mod sanitize;
pub mod sections;
pub mod svg;

pub use sections::twin;
