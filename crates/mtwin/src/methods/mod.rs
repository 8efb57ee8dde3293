pub mod skiving;
