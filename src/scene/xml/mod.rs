//! Mitsuba XML scene files: parsing to an IR with source locations ([`parse`]), upgrading the old
//! dialect ([`upgrade`]) and typed property access with unreferenced-property detection
//! ([`props`]).

pub mod parse;
pub mod props;
pub mod upgrade;

pub use crate::spectrum::SpectrumUse;
pub use parse::{load_file, load_str, Attr, Document, LoadOptions, Node};
pub use props::Props;
pub use upgrade::camel_case_hint;
