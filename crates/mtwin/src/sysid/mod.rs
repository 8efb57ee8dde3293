//! sysid
