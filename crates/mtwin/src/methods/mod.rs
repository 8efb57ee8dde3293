pub mod compensate;
pub mod thermal;
