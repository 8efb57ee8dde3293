pub mod path3d;
pub mod svg;
