//! What strahl asks of the operating system: reading input files without hanging or
//! exhausting memory ([`read`]), writing outputs atomically ([`atomic`]), telling whether two
//! paths are one file ([`same_file`]), and SIGINT/SIGTERM ([`signals`]).

pub mod atomic;
pub mod memory;
pub mod read;
pub mod same_file;
pub mod signals;
pub mod temporary;

pub use atomic::{WriteError, write_atomically};
