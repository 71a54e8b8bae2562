//! Mitsuba XML scene files: decoding their text ([`decode`]), the intermediate representation ([`ir`]), parsing to it with source
//! locations ([`parse`]), upgrading the old dialect ([`upgrade`]) and typed property access with
//! unreferenced-property detection ([`props`]), and `<transform>` composition ([`transform`]).

pub mod decode;
pub mod ir;
pub mod parse;
pub mod props;
pub mod transform;
pub mod upgrade;
