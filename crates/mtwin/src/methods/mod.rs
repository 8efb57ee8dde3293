//! The measurement methods, each a measurement model on the shared kinematics and
//! identification engines: ballbar (spec 01), tracker (02), skiving (03), thermal (04),
//! and the program rewriters built on them (geometric compensation of part programs).

pub mod ballbar;
pub mod compensate;
pub mod skiving;
pub mod testpiece;
#[warn(missing_docs)]
pub mod thermal;
pub mod tracker;
#[warn(missing_docs)]
pub mod twin;
