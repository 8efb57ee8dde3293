pub mod thermal;
