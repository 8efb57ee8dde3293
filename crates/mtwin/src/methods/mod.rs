pub mod ballbar;
