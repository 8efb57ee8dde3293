//! Machining test pieces written as five-axis programs for a given machine.
//!
//! * [`s_shape`]: the S-shaped test piece of ISO 10791-7 (the part the
//!   digital-twin patent \[R5\] machines): a ruled surface between two S
//!   curves at two heights, flank-milled.

pub mod doc;
pub mod s_shape;

pub use doc::SShapeProgramDoc;

pub use s_shape::{SShape, SShapeError, SShapeProgram, run, s_shape_poses, s_shape_program};
