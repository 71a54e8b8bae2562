//! Mitsuba XML scene files: the intermediate representation ([`ir`]), parsing to it with source
//! locations ([`parse`]), upgrading the old dialect ([`upgrade`]) and typed property access with
//! unreferenced-property detection ([`props`]).

pub mod ir;
pub mod parse;
pub mod props;
pub mod upgrade;
