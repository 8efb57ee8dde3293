pub mod thermal;
pub mod compensate;
