//! The measurement methods, each a measurement model on the shared kinematics and
//! identification engines: ballbar (\[R1\]), tracker (\[R2\]), skiving (\[R3\]), thermal (\[R4\]),
//! and the program rewriters built on them (geometric compensation of part programs).

pub mod ballbar;
pub mod compensate;
#[warn(missing_docs)]
pub mod positioning;
pub mod skiving;
pub mod testpiece;
#[warn(missing_docs)]
pub mod thermal;
pub mod tracker;
#[warn(missing_docs)]
pub mod twin;

#[cfg(test)]
mod located_messages_tests;
