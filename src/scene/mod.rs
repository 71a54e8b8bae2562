//! Scene loading: the XML front end ([`xml`]); instantiation into a renderable scene follows.

pub mod xml;
